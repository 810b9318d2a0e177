"""Calibration records from every reduction, by one code path.

:func:`records` turns any :class:`~accelcal.results.Reduction` into one
:class:`~accelcal.io.calibration_record.CalibrationRecord` per sensor:
the coefficients the design determines with their covariance, the
:class:`~accelcal.model.ErrorModel` the reduction says they define (the
indexing head's, from Dong2014 eq. (5)), and notes built from the
reduction's fields (assumptions, fixed terms, identifiability, determined
combinations).

Serial numbers, operator, date and local gravity come from the record
files' laboratory metadata (:mod:`accelcal.io.lab_metadata`) unless given
explicitly (:func:`lab_info`). Several records for one output file are
written as ``FILE`` with ``-1``, ``-2``, ... inserted before the suffix
(:func:`record_paths`), in sensor (or amplitude) order, so each file stays
one record that ``accelcal records add`` and ``accelcal report`` read.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021.
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers.
"""

import dataclasses
import datetime as dt
import math
import os
import stat
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import LabInfo, read_lab_metadata
from accelcal.io.limits import file_type
from accelcal.polar import stacked_index
from accelcal.validation import shown, shown_path


def now() -> str:
    """The current UTC time, ISO 8601 with microseconds (distinct for every run)."""
    return dt.datetime.now(dt.UTC).isoformat(timespec="microseconds")


def lab_info(files, *, sensors: int | None = None, serial: str | None = None,
             operator: str | None = None) -> LabInfo:
    """Laboratory metadata of a calibration's input files, with overrides.

    Parameters
    ----------
    files : sequence of path-like
        The input record files; their ``serial``, ``operator``, ``date`` and
        ``local_gravity`` must agree.
    sensors : int, optional
        Sensor columns per file (indexing head).
    serial : str, optional
        Serial number(s) overriding the files': one, or comma-separated one
        per sensor.
    operator : str, optional
        Operator overriding the files'.

    Returns
    -------
    LabInfo

    Raises
    ------
    AccelcalError
        When files disagree, or when no serial number is given by either.
    """
    infos = [read_lab_metadata(f, sensors) for f in files]
    merged = {}
    overridden = {"serials": serial is not None, "operator": operator is not None}
    for field in ("serials", "operator", "date", "local_gravity"):
        values = {getattr(i, field) for i in infos} - {None, ""}
        if len(values) > 1 and not overridden.get(field):
            raise AccelcalError(
                f"the input files disagree on their {field.rstrip('s')} "
                f"({', '.join(map(str, sorted(values, key=str)))}); calibrate them separately"
            )
        merged[field] = values.pop() if values else None
    serials = merged["serials"]
    if serial is not None:
        items = tuple(s.strip() for s in serial.split(","))
        count = sensors or 1
        if any(not s for s in items) or len(items) != count:
            raise AccelcalError(
                f"{shown(serial)}: give {count} non-empty serial number(s), comma separated "
                "(one per sensor column)", parameter="serial"
            )
        serials = items
    if serials is None:
        raise AccelcalError(
            "no serial number: the input files have no 'serial' metadata; give one",
            parameter="serial",
        )
    return LabInfo(serials, operator if operator is not None else merged["operator"] or "",
                   merged["date"] or "", merged["local_gravity"],
                   simulated=any(i.simulated for i in infos))


FEW_DOF = 10
"""Below this many degrees of freedom a record warns that its standard uncertainties are
themselves uncertain (relative SD ``1/sqrt(2 dof)``, over 22 %)."""

COVERAGE_PROBABILITY = 0.9545
"""The coverage probability of the expanded uncertainty: that of k = 2 for a normal
distribution, so k = 2 when the noise level is known (GUM G.3, Table G.2)."""


def coverage_factor(dof: int) -> float:
    """Student's t for ``dof`` degrees of freedom at :data:`COVERAGE_PROBABILITY` (2 for 0).

    ``dof = 0`` means the variance did not come from residuals (the noise
    level was given): the normal distribution's k = 2.

    References
    ----------
    .. [1] JCGM 100:2008 (GUM), G.3 and Table G.2 (t_p(nu) for p = 95.45 %).
    """
    if dof <= 0:
        return 2.0
    from scipy.stats import t

    return float(t.ppf(0.5 + COVERAGE_PROBABILITY / 2, dof))


def _lab_notes(info: LabInfo) -> list[str]:
    notes = []
    if info.simulated:
        notes.append("simulated data: the inputs were written by a simulator, not measured")
    if info.local_gravity is not None:
        notes.append(f"local gravity {info.local_gravity:.6g} m/s^2 (from the input files)")
    return notes


def _dof_notes(dof: int, k: float) -> list[str]:
    if dof <= 0:
        return []
    notes = [(f"standard uncertainties from the residuals with {dof} degrees of freedom; "
              f"expanded with Student's t, k = {k:.3g} (95.45 %)")]
    if dof < FEW_DOF:
        notes.append(f"only {dof} degrees of freedom (fewer than {FEW_DOF}): the standard "
                     f"uncertainties are themselves uncertain by about "
                     f"{100 / (2 * dof) ** 0.5:.0f} %; add positions or repeats")
    return notes


def records(reduction, info: LabInfo, *, input_files=(), date: str | None = None
            ) -> list[CalibrationRecord]:
    """One calibration record per sensor of any reduction.

    Each record holds the sensor's coefficients that the design determines
    (a coefficient with an undetermined value is left out; its determined
    combinations are written as notes), their covariance, the
    :class:`~accelcal.model.ErrorModel` the reduction says they define
    (``reduction.models``) and notes built from the reduction's fields
    (:func:`accelcal.outputs.describe`): assumptions, fixed terms,
    identifiability, combinations, the degrees of freedom, then whether the
    data were simulated and the laboratory's local gravity. The expanded
    uncertainty uses Student's t for the reduction's degrees of freedom
    (:func:`coverage_factor`); the record carries those ``dof`` and the
    ``simulated`` flag (from the files' metadata or the reduction's
    provenance).

    Parameters
    ----------
    reduction : accelcal.results.Reduction
    info : LabInfo
        Serial numbers (one per sensor, or one for a single sensor),
        operator, date, local gravity.
    input_files : sequence of path-like
        Files hashed into the records.
    date : str, optional
        Calibration date; default the files' date, else now.

    Returns
    -------
    list of CalibrationRecord
        In sensor order.

    Raises
    ------
    AccelcalError
        When the serial numbers do not match the sensors, or a sensor has no
        determined coefficient.
    """
    from accelcal.outputs import describe

    k = reduction.n_sensors
    if info.serials is None or len(info.serials) not in ({1, k} if k == 1 else {k}):
        raise AccelcalError(f"{k} sensors need {k} serial numbers", parameter="serial")
    common = describe(reduction)
    k_cov = coverage_factor(reduction.dof)
    out = []
    for i, (name, est) in enumerate(zip(reduction.sensor_names, reduction.sensors, strict=True)):
        keep = [j for j, v in enumerate(est.values) if np.isfinite(v)]
        if not keep:
            raise AccelcalError(
                f"the {reduction.method} reduction determined no coefficient of sensor {name}; "
                "there is nothing to record"
            )
        rows = stacked_index(keep) if est.is_complex else keep  # complex: (Re, Im) rows
        # The sensor's Estimate class, taken from the reduction: this module needs no import
        # of accelcal.results, whose Reduction.to_records calls records.
        # Rows are recorded under their names (a combination's, e.g. K0+Kpp), the plain
        # coefficient's name beside them.
        labels = [est.label(est.names[j]) for j in keep]
        sub = type(est)(
            tuple(labels), est.values[keep], est.covariance[np.ix_(rows, rows)],
            {lab: est.units.get(est.names[j], "") for lab, j in zip(labels, keep, strict=True)},
            reduction.method, residuals=est.residuals, dof=est.dof,
        )
        plain = {lab: est.names[j] for lab, j in zip(labels, keep, strict=True)
                 if lab != est.names[j]}
        type_b = {} if est.is_complex else _type_b_of(reduction, i, labels,
                                                      [est.names[j] for j in keep])
        head = ([f"sensor column {name} of {k}; reduction {reduction.method}"] if k > 1 else [])
        notes = [*head, *common, *(n for n in est.notes if n not in common),
                 *_dof_notes(reduction.dof, k_cov), *_lab_notes(info)]
        record = CalibrationRecord.from_estimate(
            sub, serial=info.serial(i), method=reduction.method, input_files=input_files,
            date=date or info.date or now(), operator=info.operator, model=reduction.models[i],
        )
        out.append(dataclasses.replace(
            record, notes=tuple(dict.fromkeys(notes)), coverage_factor=k_cov,
            dof=reduction.dof if reduction.dof > 0 else None,
            simulated=info.simulated or bool(reduction.provenance.get("simulated")),
            plain=plain, type_b=type_b,
        ))
    return out


def _type_b_of(reduction, sensor: int, labels, names) -> dict:
    """Row label -> its combined Type B standard uncertainty, for the rows that have one.

    The root sum of squares of the row's itemised contributions
    (:meth:`accelcal.results.Reduction.contributions`; the priors are
    independent, so this is the Type B part of the row's variance, GUM 5.1.2).
    """
    out = {}
    for label, name in zip(labels, names, strict=True):
        parts = reduction.contributions(name, sensor)
        if parts:
            out[label] = math.sqrt(sum(c.contribution**2 for c in parts))
    return out


def record_paths(path, count: int) -> list[Path]:
    """Files for ``count`` records asked for as ``path``.

    One record is written to ``path``; several to ``path`` with ``-1``,
    ``-2``, ... inserted before the suffix (``cal.json`` -> ``cal-1.json``).

    Raises
    ------
    AccelcalError
        (parameter ``record``) For an empty path or one without a file name
        (``.``, ``dir/``), a directory, or a path that (or any derived path
        that) exists and is not a regular file (a FIFO, a device such as
        ``/dev/full``): records go beside ``path``, never into or over such
        a file.
    """
    text = os.fspath(path)
    path = Path(text)
    if not text or not path.name or path.name in (".", "..") or text.endswith(os.sep):
        raise AccelcalError(f"{shown_path(text) or 'an empty path'} is not a file name; give the "
                            "file to write the record to (e.g. cal.json)", parameter="record")
    paths = [path] if count == 1 else [path.with_name(f"{path.stem}-{i}{path.suffix}")
                                       for i in range(1, count + 1)]
    for p in dict.fromkeys([path, *paths]):
        try:
            mode = os.stat(p).st_mode
        except (OSError, ValueError):  # new, or unusable: the writer says why
            continue
        if not stat.S_ISREG(mode):
            raise AccelcalError(
                f"{shown_path(p)} is {file_type(mode)}, not a regular file; give the name of a "
                "file to write the record to (several records go beside it, as NAME-1, "
                "NAME-2, ...)", parameter="record")
    return paths


def save_records(records, path) -> list[Path]:
    """Write records to :func:`record_paths` (each file atomically); return the paths.

    Every record is serialised before any file is written, and the directory
    must exist, so a failure writes nothing.
    """
    paths = record_paths(path, len(records))
    if not paths[0].parent.is_dir():
        raise AccelcalError(f"{path}: directory {paths[0].parent} does not exist",
                            parameter="record")
    texts = [r.to_json() for r in records]
    from accelcal.io.atomic import write_text_atomic

    for p, text in zip(paths, texts, strict=True):
        write_text_atomic(p, text)
    return paths
