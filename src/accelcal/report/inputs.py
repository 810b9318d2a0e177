"""What ``accelcal report`` reads: the files accelcal writes, each to its section.

:func:`report_sections` takes calibration records (``--record`` of every
reduction command) and triad calibration files (``accelcal triad calibrate
--out``) and a reduction's JSON output (``--format json``: its
coefficients, without figures, which need the observations it does not
hold). Records of one reduction (same method, date and input files: the
sensors of an indexing head) are reported together, through the reduction
rebuilt from them (:func:`accelcal.report.rebuild.rebuild`) and the same
section builder as the demo's
(:func:`accelcal.report.sections.reduction_sections`). Any other file
accelcal writes (thermal compensation, error model, a triad calibration in
imucal's layout, a Kalibr noise file, a record file of data) is named in a
one-line error saying what to give instead.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., A robust and easy to
   implement method for IMU calibration without external equipments, ICRA
   2014, eq. (8)-(10) (the triad model).
"""

import dataclasses
from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.report import Section
from accelcal.validation import shown_path

TAKES = ("report takes calibration records (written by a reduction command's --record FILE), "
         "triad calibration files (accelcal triad calibrate --out) and a reduction's JSON "
         "output (--format json)")
"""What a refused file is told."""

OTHER_KINDS = {
    "accelcal.ThermalCompensation": "a thermal compensation file (accelcal thermal reduce "
                                    "--compensation)",
    "accelcal.ErrorModel": "an error model file (accelcal model, accelcal thermal reduce "
                           "--model-out)",
}
"""The ``kind`` of accelcal's other JSON files -> what they are."""


NO_OBSERVATIONS = ("No figures: a reduction's JSON output holds its coefficients, not the "
                   "observations the figures are drawn from; report the calibration records "
                   "(--record FILE) beside their input files for the figures.")
"""The first note of a reduction reported from its JSON output."""

FROM_JSON = ("Reported from a reduction's JSON output: its coefficients with their standard "
             "uncertainties, per sensor; no serial numbers, no record.")
"""The summary of a reduction reported from its JSON output."""


def read_input(path):
    """A calibration record, a triad calibration or a reduction from ``path``.

    Returns
    -------
    CalibrationRecord, TriadCalibration or accelcal.results.Reduction

    Raises
    ------
    AccelcalError
        One line naming the file, what it is when it is another accelcal
        file, and what report takes.
    """
    from accelcal.io.calibration_record import KIND, CalibrationRecord
    from accelcal.io.limits import MAX_JSON_BYTES, load_json, read_bounded
    from accelcal.methods.triad.model import FORMAT, TriadCalibration

    path = Path(path)
    name = shown_path(path)
    try:
        raw = read_bounded(path, MAX_JSON_BYTES, "calibration record")
    except FileNotFoundError:
        raise AccelcalError(f"calibration record {path} not found") from None
    except OSError as exc:
        raise AccelcalError(f"cannot read {name}: {exc.strerror or exc}") from None
    try:
        data = load_json(raw.decode("utf-8"), name)
    except (AccelcalError, UnicodeDecodeError):
        raise AccelcalError(f"{name} is not JSON{_data_kind(path, raw)}; {TAKES}") from None
    if not isinstance(data, dict):
        raise AccelcalError(f"{name} is not a calibration record (not a JSON object); {TAKES}")
    if data.get("format") == FORMAT:
        return TriadCalibration.from_dict(data, f"triad calibration {name}")
    kind = data.get("kind")
    if isinstance(kind, str) and kind in OTHER_KINDS:
        raise AccelcalError(f"{name} is {OTHER_KINDS[kind]}; {TAKES}")
    if kind != KIND and {"K_a", "R_a", "b_a"} <= set(data):
        raise AccelcalError(f"{name} is a triad calibration in imucal's layout (accelcal triad "
                            f"calibrate --imucal-out); give the one of --out instead; {TAKES}")
    if kind != KIND and {"family", "method", "sensors"} <= set(data):
        return _reduction(data, name)
    if kind != KIND:
        raise AccelcalError(f"{name} is not a calibration record (kind is not {KIND!r}); {TAKES}")
    return CalibrationRecord.from_json(raw.decode("utf-8"), source=name)


def _reduction(data: dict, name: str):
    """The reduction of a reduction's JSON output, or one line saying it is not readable."""
    from accelcal.results import Reduction

    try:
        return Reduction.from_dict(data, source=name)
    except (AccelcalError, ValueError, KeyError, TypeError) as exc:
        raise AccelcalError(f"{name} looks like a reduction's JSON output (--format json) but "
                            f"cannot be read ({exc}); {TAKES}") from None


def _data_kind(path: Path, raw: bytes = b"") -> str:
    """What a file that is not JSON is, when accelcal wrote it: ``: it is ...``, else ``""``.

    A records store (SQLite), a Kalibr IMU noise file (``accelcal noise ...
    --export``) or a record file of data (its metadata's ``kind``).
    """
    from accelcal.io.lab_metadata import read_metadata

    if raw.startswith(b"SQLite format 3\x00"):
        return (": it is a records store; give record files, and --history --db FILE for "
                "the store's calibration history")
    if b"accelerometer_noise_density" in raw[:4096]:
        return (": it is a Kalibr IMU noise file (exported from a noise fit); report the noise "
                "fit's calibration record (--record FILE) instead")

    try:
        kind = read_metadata(path).get("kind")
    except (AccelcalError, OSError, ValueError):
        return ""
    if not isinstance(kind, str):
        return ""
    return (f": it is a record file of data (kind {kind!r}); reduce it with its method's "
            "command and --record FILE, then report the record")


def report_sections(paths, *, search=()) -> list[Section]:
    """The sections of ``accelcal report``: one group of records or one file at a time.

    Parameters
    ----------
    paths : sequence of path-like
        Calibration records, triad calibration files and reductions' JSON
        outputs, in the order wanted.
    search : sequence of path-like
        Directories holding the records' input files (besides the records'
        own directories and the working directory).

    Returns
    -------
    list of Section
        Every file is read and validated before any figure is drawn.
    """
    from accelcal.methods.triad.model import TriadCalibration
    from accelcal.report.rebuild import family_of, rebuild
    from accelcal.report.sections import reduction_sections
    from accelcal.results import Reduction

    items = [(Path(p), read_input(p)) for p in paths]
    for d in search:
        if not Path(d).is_dir():
            raise AccelcalError(f"--data {shown_path(d)}: not a directory; "
                                "give the directory holding the records' input files",
                                parameter="data")
    groups: dict = {}
    for path, item in items:
        alone = isinstance(item, TriadCalibration | Reduction)
        key = (("file", str(path)) if alone else
               (item.method, item.date, tuple(item.inputs.items())))
        same = (str(path.resolve()) if alone else
                (item.serial, item.names, item.estimates.tobytes()))
        groups.setdefault(key, {}).setdefault(same, (path, item))  # a record given twice: once
    sections = []
    for group in groups.values():
        members = list(group.values())
        path, item = members[0]
        if isinstance(item, TriadCalibration):
            sections.append(triad_calibration_section(item, path.name))
            continue
        if isinstance(item, Reduction):
            first, *rest = reduction_sections(item, [None] * item.n_sensors,
                                              unavailable=NO_OBSERVATIONS)
            sections += [dataclasses.replace(first, title=f"{path.name}: {first.title}",
                                             summary=FROM_JSON), *rest]
            continue
        if family_of(item.method) is None:  # a method accelcal does not know: the records
            sections += [Section(f"{r.serial}: {r.method}", r) for _, r in members]
            continue
        built = rebuild([r for _, r in members], [p for p, _ in members], search)
        sections += reduction_sections(built.reduction, built.records,
                                       unavailable=built.unavailable, **built.context)
    return sections


def triad_calibration_section(cal, name: str) -> Section:
    """A triad calibration file's section: its model and parameters (no uncertainties).

    References
    ----------
    .. [1] Tedaldi2014, eq. (8)-(10).
    """
    from accelcal.formatting import format_unit
    from accelcal.methods.triad.model import PARAMS, QUADRATIC, units_of

    quadratic = cal.quadratic is not None
    names = PARAMS + (QUADRATIC if quadratic else ())
    units = units_of(cal.input_unit, quadratic)
    meaning = {"b": "bias", "s": "scale factor", "a": "non-orthogonality angle",
               "q": "quadratic term"}
    values = dict(zip(names, (float(v) for v in cal.vector), strict=True))
    rows = [{"parameter": n, "value": v, "unit": format_unit(units[n]),
             "in field units": _field(n, v, units[n], values), "meaning": meaning[n[0]]}
            for n, v in values.items()]
    notes = [("a triad calibration file holds the model only, without uncertainties: the "
              "calibration record (accelcal triad calibrate --record FILE) carries them")]
    if cal.rotation is not None:
        notes.append("the file holds a body-to-reference rotation (apply with "
                     "frame='reference'): "
                     + "; ".join(" ".join(f"{x:.6g}" for x in row) for row in cal.rotation))
    return Section(
        title=f"{name}: triad calibration",
        summary=("Calibrated specific force a = T (p + q p²), p = diag(s) (u - b), of the raw "
                 f"output u in {cal.input_unit}, in m/s^2 (Tedaldi2014 eq. (8)-(10); T is "
                 "upper triangular with the angles a_yz, a_zy, a_zx)."),
        rows=rows, notes=tuple(notes),
    )


def _field(name: str, value: float, unit: str, values: dict) -> str:
    """A triad parameter in field units (no uncertainty: the file holds none)."""
    from accelcal.formatting import format_unit
    from accelcal.report.units import field_values

    axis = name[2:3]
    found = field_values(name, value, 0.0, unit,
                         axis_scale=values.get(f"s_{axis}") if name.startswith("b_") else None)
    field = found[0]
    return f"{field.estimate:.7g} {format_unit(field.unit)}"
