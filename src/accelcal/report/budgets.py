"""The reductions behind calibration records, with their input data, for their budgets.

:func:`gather` turns the files given into reductions with their input data:
calibration records through the report's road (the input files found by
name and SHA-256 and reduced again, :func:`accelcal.report.rebuild.rebuild`;
when they are not found the budget keeps the record's own numbers and the
inputs entering through the data are left out), record files of data
through their method's ``reduce`` with its default settings. It serves
``accelcal budget``, the certificate and the report's budget annex
(:func:`record_budgets`).
"""

import dataclasses
from pathlib import Path

from accelcal.errors import AccelcalError


def _method_of_family(family: str):
    from accelcal import catalog

    return next((m for m in catalog.METHODS if m.family == family), None)


def gather(paths, search=()):
    """``(reduction, input data, sensors or None, method descriptor)`` for the files given.

    Records of one reduction (same method, date and inputs) are taken
    together; ``sensors`` is the set of the reduction's sensors they are
    records of (None: every sensor, a data file).
    """
    from accelcal import catalog
    from accelcal.io.lab_metadata import read_metadata
    from accelcal.report.inputs import read_input

    groups: dict = {}
    for path in map(Path, paths):
        kind = None
        if path.suffix.lower() in (".csv", ".parquet"):
            try:
                kind = read_metadata(path).get("kind")
            except (AccelcalError, OSError, ValueError):
                kind = None
        if isinstance(kind, str):
            method = next((m for m in catalog.METHODS if kind in m.kinds), None)
            if method is None:
                raise AccelcalError(f"{path}: record kind {kind!r} belongs to no method")
            reduce = catalog.resolve(f"{method.package}.reduce")
            yield reduce(path), path, None, method
            continue
        item = read_input(path)
        if not hasattr(item, "method"):
            raise AccelcalError(f"{path} is a triad calibration file (model only, no "
                                "uncertainty); give its calibration record (accelcal triad "
                                "calibrate --record FILE)")
        key = (item.method, item.date, tuple(item.inputs.items()))
        groups.setdefault(key, []).append((path, item))
    for members in groups.values():
        yield _from_records(members, search)


def _from_records(members, search):
    from accelcal.report.rebuild import find_inputs, rebuild

    recs = [r for _, r in members]
    built = rebuild(recs, [p for p, _ in members], search)
    files = []
    if not built.unavailable:
        files, _ = find_inputs(recs[0], members[0][0], search)
    sensors = {k for k, r in enumerate(built.records) if r is not None}
    reduction = built.reduction
    names = [r.serial if r is not None else n
             for r, n in zip(built.records, reduction.sensor_names, strict=True)]
    if len(set(names)) == len(names):  # the budgets named by the records' serial numbers
        reduction = dataclasses.replace(reduction, sensor_names=tuple(names))
    return reduction, (files or None), sensors, _method_of_family(reduction.family)


def record_budgets(paths, lab, search=()) -> dict:
    """The budgets of the calibration records among ``paths``, for a report's summary and annex.

    Parameters
    ----------
    paths : sequence of path-like
        The files a report is made of; those that are not calibration
        records (triad calibration files, reductions' JSON outputs) have no
        budget and are passed over.
    lab : accelcal.budget.lab.Lab
    search : sequence of path-like
        More directories holding the records' input files (:func:`gather`).

    Returns
    -------
    dict
        ``(serial, method) -> list of`` :meth:`Budget.as_dict`, as
        :func:`accelcal.report.render_report` takes them.
    """
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.report.inputs import read_input

    paths = [p for p in map(Path, paths) if isinstance(read_input(p), CalibrationRecord)]
    return calibration_budgets(paths, lab, search)


def calibration_budgets(paths, lab, search=()) -> dict:
    """:func:`record_budgets` of paths that are all calibration records (not read to check).

    The records are reduced again from their input files (:func:`gather`),
    and each sensor the records name gets :func:`accelcal.budget.budgets`'
    budgets, keyed ``(serial, method)``.
    """
    from accelcal.budget import budgets

    out: dict = {}
    for reduction, inputs, sensors, _ in gather(paths, search):
        for b in budgets(reduction, lab, records=inputs):
            if sensors is None or b.sensor in sensors:
                out.setdefault((b.serial, reduction.method), []).append(b.as_dict())
    return out
