"""Calibration records from every reduction.

Each test method's reduction result becomes one or more
:class:`~accelcal.io.calibration_record.CalibrationRecord`:

* indexing head (:func:`head_records`): one record per sensor with K_F,
  K_I, K_O, K_IO, K_II (output unit) and their covariance, the
  :class:`~accelcal.model.ErrorModel` they define
  (:meth:`~accelcal.model.ErrorModel.from_dong2014`), and the reduction's
  notes;
* vibration rectification (:func:`vre_record`): the fitted VRE
  coefficients (g/g^n); coefficients the design cannot identify are left
  out and the combinations it does determine are written as notes;
* transverse sensitivity (:func:`transverse_record`): k_o, k_p, k_oo,
  k_pp, k_op (accelcal names Ko, Kp, Koo, Kpp, Kop; g/g^n).

Serial numbers, operator, date and local gravity come from the record
files' laboratory metadata (:mod:`accelcal.io.lab_metadata`) unless given
explicitly (:func:`lab_info`). Several records for one ``--record FILE``
are written as ``FILE`` with ``-1``, ``-2``, ... inserted before the suffix
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
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import LabInfo, read_lab_metadata, read_metadata


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
                f"--serial {serial!r}: give {count} non-empty serial number(s), comma separated "
                "(one per sensor column)"
            )
        serials = items
    if serials is None:
        raise AccelcalError(
            "no serial number: the input files have no 'serial' metadata; give --serial"
        )
    return LabInfo(serials, operator if operator is not None else merged["operator"] or "",
                   merged["date"] or "", merged["local_gravity"])


def _lab_notes(info: LabInfo) -> list[str]:
    if info.local_gravity is None:
        return []
    return [f"local gravity {info.local_gravity:.6g} m/s^2 (from the input files)"]


def _residual_sigma(est) -> float:
    """Residual standard deviation of an estimate (0 when it has no residuals or dof)."""
    if est.residuals is None or not est.dof:
        return 0.0
    r = np.asarray(est.residuals, dtype=float)
    return float(np.sqrt(np.sum(r**2) / est.dof))


def _pooled_sigma(result) -> float:
    """Noise SD of a joint head reduction: all residuals over the joint degrees of freedom.

    The joint fit estimates every sensor's coefficients and the head errors
    together, so its degrees of freedom (each sensor's ``dof``) are shared.
    """
    est = result.sensors[0]
    if not est.dof:
        return 0.0
    return float(np.sqrt(np.sum(result.residuals() ** 2) / est.dof))


def head_records(result, info: LabInfo, *, sensor_names=None, input_files=(),
                 date: str | None = None) -> list[CalibrationRecord]:
    """One calibration record per sensor of an indexing-head reduction.

    Parameters
    ----------
    result : accelcal.methods.dividing_head.HeadReduction
        The reduction.
    info : LabInfo
        Serial numbers (one per sensor), operator, date, local gravity.
    sensor_names : sequence of str, optional
        Column names, written into each record's notes.
    input_files : sequence of path-like
        Files hashed into the records.
    date : str, optional
        Calibration date; default the files' date, else now.

    Returns
    -------
    list of CalibrationRecord
        Coefficients K_F, K_I, K_O, K_IO, K_II in the output unit; the model
        is :meth:`ErrorModel.from_dong2014` of the estimates with sigma from
        the residuals (pooled over the sensors for the joint reduction, whose
        degrees of freedom they share; per sensor otherwise).

    References
    ----------
    .. [1] Dong2014, eq. (5) (coefficient definitions).
    """
    from accelcal.model import ErrorModel

    k = len(result.sensors)
    if info.serials is None or len(info.serials) != k:
        raise AccelcalError(f"{k} sensors need {k} serial numbers")
    names = list(sensor_names) if sensor_names is not None else [f"U{i + 1}" for i in range(k)]
    pooled = _pooled_sigma(result) if result.method == "joint" else None
    records = []
    for i, est in enumerate(result.sensors):
        unit = est.units.get("K_I", "V/g").split("/")[0]
        values = dict(zip(est.names, est.values, strict=True))
        sigma = pooled if pooled is not None else _residual_sigma(est)
        model = ErrorModel.from_dong2014(  # Eq. (5) [Dong2014]
            values["K_F"], values["K_I"], values["K_O"], values["K_IO"], values["K_II"],
            output_unit=unit, sigma=sigma if math.isfinite(sigma) else 0.0,
        )
        notes = [f"sensor column {names[i]} of {k} on the head; reduction {result.method}",
                 *result.notes, *(n for n in est.notes if n not in result.notes),
                 *_lab_notes(info)]
        records.append(_record(est, serial=info.serial(i), method=f"dividing-head/{result.method}",
                               info=info, input_files=input_files, date=date, model=model,
                               notes=notes))
    return records


def vre_record(fit, info: LabInfo, *, input_files=(), date: str | None = None
               ) -> CalibrationRecord:
    """The calibration record of a VRE identification.

    Coefficients the (overload, amplitude) design cannot identify are left
    out; the linear combinations of them that it determines, and the
    coefficients held fixed, are written as notes.

    Parameters
    ----------
    fit : accelcal.methods.vre.VreFit
        The identification.
    info : LabInfo
    input_files : sequence of path-like
    date : str, optional

    Raises
    ------
    AccelcalError
        When no coefficient was identified.

    References
    ----------
    .. [1] Guan2021, eqs. (9), (21) (the VRE model the coefficients enter).
    """
    from accelcal.methods.vre import describe_combination
    from accelcal.results import Estimate

    est = fit.estimate
    keep = [i for i, n in enumerate(est.names) if n not in fit.unidentifiable]
    if not keep:
        raise AccelcalError("the VRE fit identified no coefficient; there is nothing to record")
    sub = Estimate(
        tuple(est.names[i] for i in keep), est.values[keep],
        est.covariance[np.ix_(keep, keep)], {est.names[i]: est.units[est.names[i]] for i in keep},
        est.method, residuals=est.residuals, dof=est.dof, notes=est.notes,
    )
    notes = list(est.notes)
    notes += [f"not identifiable from this design: {name}" for name in fit.unidentifiable]
    notes += [f"determined combination {describe_combination(w)} = {v:.6g} +- {s:.2g}"
              for w, v, s in fit.combinations]
    notes += [f"{name} held fixed at {value:.6g}" for name, value in fit.fixed.items()]
    notes += _lab_notes(info)
    return _record(sub, serial=info.serial(), method=est.method, info=info,
                   input_files=input_files, date=date, model=None, notes=notes)


def transverse_record(estimate, info: LabInfo, *, amplitude: float | None = None,
                      input_files=(), date: str | None = None) -> CalibrationRecord:
    """The calibration record of a transverse (cross-axis) identification.

    Parameters
    ----------
    estimate : accelcal.results.Estimate
        :func:`accelcal.methods.transverse.identify` result (Ko, Kp, Koo,
        Kpp, Kop, ... in g/g^n).
    info : LabInfo
    amplitude : float, optional
        Vibration amplitude of the records, g (written to the notes).
    input_files : sequence of path-like
    date : str, optional

    References
    ----------
    .. [1] GuanTang eqs. (13), (16); docs/domain.md section 3.
    """
    notes = list(estimate.notes)
    if amplitude is not None:
        notes.insert(0, f"shaker vibration amplitude {amplitude:g} g")
    notes += _lab_notes(info)
    return _record(estimate, serial=info.serial(), method=estimate.method, info=info,
                   input_files=input_files, date=date, model=None, notes=notes)


def _record(est, *, serial, method, info, input_files, date, model, notes) -> CalibrationRecord:
    record = CalibrationRecord.from_estimate(
        est, serial=serial, method=method, input_files=input_files,
        date=date or info.date or now(), operator=info.operator, model=model,
    )
    return dataclasses.replace(record, notes=tuple(dict.fromkeys(notes)))


def shaker_files(path) -> dict[float, list[Path]]:
    """Shaker record files of a directory (or one file), grouped by amplitude (g).

    The grouping is that of :func:`accelcal.rigs.shaker.read_records`, so
    each amplitude's calibration record hashes exactly its own files.
    """
    path = Path(path)
    files = sorted([*path.glob("*.csv"), *path.glob("*.parquet")]) if path.is_dir() else [path]
    groups: dict[float, list[Path]] = {}
    for f in files:
        amplitude = read_metadata(f).get("amplitude_g")
        if isinstance(amplitude, bool) or not isinstance(amplitude, int | float):
            raise AccelcalError(f"{f}: metadata amplitude_g must be a number")
        groups.setdefault(float(amplitude), []).append(f)
    return groups


def record_paths(path, count: int) -> list[Path]:
    """Files for ``count`` records asked for as ``path``.

    One record is written to ``path``; several to ``path`` with ``-1``,
    ``-2``, ... inserted before the suffix (``cal.json`` -> ``cal-1.json``).
    """
    path = Path(path)
    if count == 1:
        return [path]
    return [path.with_name(f"{path.stem}-{i}{path.suffix}") for i in range(1, count + 1)]


def save_records(records, path) -> list[Path]:
    """Write records to :func:`record_paths` (each file atomically); return the paths.

    Every record is serialised before any file is written, and the directory
    must exist, so a failure writes nothing.
    """
    paths = record_paths(path, len(records))
    if not paths[0].parent.is_dir():
        raise AccelcalError(f"--record {path}: directory {paths[0].parent} does not exist")
    texts = [r.to_json() for r in records]
    from accelcal.io.atomic import write_text_atomic

    for p, text in zip(paths, texts, strict=True):
        write_text_atomic(p, text)
    return paths
