"""The reduction behind calibration records, rebuilt for their report.

A calibration record holds one sensor's estimates, covariance, notes and the
SHA-256 of every input file; the report's figures need more (residuals, the
data the fit used, the method's assumptions). :func:`rebuild` finds the
input files a group of records names by hash (next to the record, in the
working directory, or in the directories given), reduces them again with
the method's settings that the record and the file determine, and keeps the
result only when it reproduces every record's estimates. The sections are
then built from that reduction by the same code as the demo's
(:func:`accelcal.report.sections.reduction_sections`), with the records'
own numbers put in place of the re-reduced ones: the numbers in a report
are always exactly the record's, and the figures are those of the data the
record names.

When the files are not found, or do not reproduce the record (made with
other options, or by an older version), the reduction is rebuilt from the
records alone (:func:`reduction_from_records`) and the section says why it
has no figures.

References
----------
.. [GUM] JCGM 100:2008, sec. 7.1 (a reported result carries what is needed
   to trace it to its data).
"""

import dataclasses
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import shown_path

SEARCH_DEPTH = 2
"""How deep below a directory given for the input files they are looked for
(``DIR/name``, ``DIR/*/name``, ``DIR/*/*/name``)."""

MATCH_RTOL = 1e-8
"""Largest relative difference between a record's estimate and the re-reduced
one that counts as the same (far above rounding across BLAS builds, far below
any change of settings)."""


@dataclasses.dataclass(frozen=True)
class Rebuilt:
    """What a report needs of one reduction, rebuilt from its records.

    Attributes
    ----------
    reduction : accelcal.results.Reduction
        With the records' numbers.
    records : list
        One per sensor of ``reduction``, in sensor order; None for a sensor
        whose record was not given.
    context : dict
        Passed to the method's figures (e.g. ``truth`` from a simulated file).
    unavailable : str
        Why there are no figures ("" when there are).
    """

    reduction: object
    records: list
    context: dict
    unavailable: str = ""


# ------------------------------------------------------------------ families
def family_of(method: str) -> str | None:
    """The method family (a key of :data:`accelcal.methods.REGISTRY`) of a record's method id.

    Ids are ``<family>/<route>`` (older ids are read through
    :func:`accelcal.method_ids.canonical`): ``dividing-head/joint`` ->
    ``dividing-head``, ``ieee952-fit`` -> ``noise``; None when unknown.
    """
    from accelcal.method_ids import canonical
    from accelcal.methods import REGISTRY

    family = canonical(method).split("/", 1)[0]
    return family if family in REGISTRY else None


# -------------------------------------------------------------------- files
def find_inputs(record, source: Path, search=()) -> tuple[list[Path], list[str]]:
    """The record's input files, found by name and checked by SHA-256.

    Looked for next to the record file ``source``, in the working directory,
    in the campaign's ``data`` directory beside the record's directory (the
    layout :func:`accelcal.pipeline.run_campaign` writes: ``records/`` and
    ``data/``) and in each directory of ``search``; below the last two up to
    :data:`SEARCH_DEPTH` levels.

    Returns
    -------
    found : list of pathlib.Path
        In the record's order (only when every file is found).
    missing : list of str
        Names not found with the recorded hash.
    """
    here = Path(source).parent
    dirs = [here, Path()]
    for root in [here.parent / "data", *map(Path, search)]:
        dirs += [root, *(d for k in range(1, SEARCH_DEPTH + 1) for d in sorted(root.glob("*/" * k))
                         if d.is_dir())]
    dirs = list(dict.fromkeys(dirs))
    found, missing = [], []
    for name, digest in record.inputs.items():
        plain = name == Path(name).name and name not in ("", ".", "..")  # as records write it
        path = next((d / name for d in dirs if plain and _hash_of(d / name) == digest), None)
        if path is None:
            missing.append(name)
        else:
            found.append(path)
    return (found if not missing else []), missing


def _hash_of(path: Path) -> str | None:
    """``sha256:<hex>`` of a regular file, None for anything else."""
    from accelcal.io.calibration_record import file_sha256

    try:
        return file_sha256(path) if path.is_file() else None
    except (AccelcalError, OSError):
        return None


# ------------------------------------------------------------ the rebuilding
def _same(est, record) -> bool:
    """Whether a sensor's estimate holds a record's numbers (to :data:`MATCH_RTOL`)."""
    keep = [i for i, v in enumerate(est.values) if np.isfinite(v)]
    values = est.values[keep]
    return (tuple(est.label(est.names[i]) for i in keep) == record.names
            and bool(np.all(np.abs(values - record.estimates)
                            <= MATCH_RTOL * np.abs(record.estimates))))


def _sensor_order(reduction, records) -> list | None:
    """Each record's sensor in ``reduction``, or None when a record is not one of them."""
    order = []
    for rec in records:
        hits = [k for k, est in enumerate(reduction.sensors)
                if k not in order and rec.method == reduction.method and _same(est, rec)]
        if not hits:
            return None
        order.append(hits[0])
    return order


def with_record_numbers(reduction, records, order):
    """``reduction`` with each given record's estimates and covariance in its sensor's place.

    The re-reduced numbers agree with the record's to :data:`MATCH_RTOL`; the
    record's are the ones reported, bit for bit. A complex coefficient takes
    its two covariance rows (real and imaginary part, :mod:`accelcal.polar`).
    """
    from accelcal.polar import stacked_index

    sensors = list(reduction.sensors)
    for rec, k in zip(records, order, strict=True):
        est = sensors[k]
        idx = [est.index(n) for n in rec.names]
        rows = stacked_index(idx) if est.is_complex else idx
        values = np.array(est.values)
        cov = np.array(est.covariance, dtype=float)
        values[idx] = rec.estimates
        cov[np.ix_(rows, rows)] = rec.covariance
        sensors[k] = dataclasses.replace(est, values=values, covariance=cov)
    return dataclasses.replace(reduction, sensors=tuple(sensors))


def reduction_from_records(records):
    """A :class:`~accelcal.results.Reduction` holding only what calibration records hold.

    One sensor per record (named by its serial number), the records'
    estimates, covariance, units, notes, degrees of freedom and error model;
    no residuals, observations or assumptions, so no figures.
    """
    from accelcal.results import Estimate, Reduction

    first = records[0]
    sensors = tuple(
        Estimate(tuple(r.plain.get(n, n) for n in r.names), r.estimates, r.covariance,
                 {r.plain.get(n, n): u for n, u in r.units.items()}, r.method, dof=r.dof or 0,
                 notes=r.notes, labels={p: n for n, p in r.plain.items()})
        for r in records)
    serials = [r.serial for r in records]
    names = serials if len(set(serials)) == len(serials) else ()
    return Reduction(family=family_of(first.method) or first.method, method=first.method,
                     sensors=sensors, sensor_names=tuple(names), dof=first.dof or 0,
                     models=tuple(r.model for r in records),
                     provenance={"simulated": any(r.simulated for r in records)})


def rebuild(records, sources, search=()) -> Rebuilt:
    """The reduction behind a group of records (same method, inputs and date).

    Parameters
    ----------
    records : sequence of CalibrationRecord
    sources : sequence of path-like
        The record files (their directories are searched for the inputs).
    search : sequence of path-like
        Further directories holding the input files.

    Returns
    -------
    Rebuilt
    """
    method = records[0].method
    family = family_of(method)
    from accelcal.methods import package

    reducer = getattr(package(family), "from_inputs", None)
    if reducer is None:
        return _alone(records, f"figures are not rebuilt for method {method!r}")
    if not records[0].inputs:
        return _alone(records, "the record names no input files")
    files, missing = find_inputs(records[0], Path(sources[0]), search)
    if missing:
        where = ", ".join(["next to the record", "in the working directory", "in ../data",
                           *(f"in {shown_path(d)}" for d in search)])
        return _alone(records, f"input file(s) {', '.join(missing)} with the recorded SHA-256 "
                               f"not found ({where}); give their directory with --data")
    tried = 0
    try:
        for reduction, context in reducer(files, records[0]):  # lazily: the first that fits
            tried += 1
            order = _sensor_order(reduction, records)
            if order is not None:
                given = [None] * reduction.n_sensors
                for rec, k in zip(records, order, strict=True):
                    given[k] = rec
                return Rebuilt(with_record_numbers(reduction, records, order), given,
                               {k: v for k, v in context.items() if v is not None})
    except (AccelcalError, ValueError, KeyError, IndexError, TypeError, OSError) as exc:
        return _alone(records, f"reducing the input files again failed ({exc})")
    if not tried:
        return _alone(records, f"figures are not rebuilt for method {method!r}")
    return _alone(records, "the input files, reduced again with the settings the record and "
                           "the files determine, do not give the record's estimates (the "
                           "record was made with other options)")


def _alone(records, why: str) -> Rebuilt:
    return Rebuilt(reduction_from_records(records), list(records), {},
                   f"No figures: {why}.")
