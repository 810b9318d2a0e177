"""What ``accelcal report`` reads: the files accelcal writes, each to its section.

:func:`report_sections` takes calibration records (``--record`` of every
reduction command) and triad calibration files (``accelcal triad calibrate
--out``). Records of one reduction (same method, date and input files: the
sensors of an indexing head) are reported together, through the reduction
rebuilt from them (:func:`accelcal.report.rebuild.rebuild`) and the same
section builder as the demo's
(:func:`accelcal.report.sections.reduction_sections`). Any other file
accelcal writes (thermal compensation, error model, a triad calibration in
imucal's layout, a reduction's JSON output, a record file of data) is
named in a one-line error saying what to give instead.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., A robust and easy to
   implement method for IMU calibration without external equipments, ICRA
   2014, eq. (8)-(10) (the triad model).
"""

from pathlib import Path

from accelcal.errors import AccelcalError
from accelcal.report import Section
from accelcal.validation import shown_path

TAKES = ("report takes calibration records (written by a reduction command's --record FILE) "
         "and triad calibration files (accelcal triad calibrate --out)")
"""What a refused file is told."""

OTHER_KINDS = {
    "accelcal.ThermalCompensation": "a thermal compensation file (accelcal thermal reduce "
                                    "--compensation)",
    "accelcal.ErrorModel": "an error model file (accelcal model, accelcal thermal reduce "
                           "--model-out)",
}
"""The ``kind`` of accelcal's other JSON files -> what they are."""


def read_input(path):
    """A calibration record or a triad calibration from ``path``.

    Returns
    -------
    CalibrationRecord or TriadCalibration

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
        raise AccelcalError(f"{name} is not JSON{_data_kind(path)}; {TAKES}") from None
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
        raise AccelcalError(f"{name} is a reduction's JSON output (--format json); {TAKES}")
    if kind != KIND:
        raise AccelcalError(f"{name} is not a calibration record (kind is not {KIND!r}); {TAKES}")
    return CalibrationRecord.from_json(raw.decode("utf-8"), source=name)


def _data_kind(path: Path) -> str:
    """`` (a record file of data, kind K)`` when ``path`` is one, else ``""``."""
    from accelcal.io.lab_metadata import read_metadata

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
        Calibration records and triad calibration files, in the order wanted.
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

    items = [(Path(p), read_input(p)) for p in paths]
    for d in search:
        if not Path(d).is_dir():
            raise AccelcalError(f"--data {shown_path(d)}: not a directory; "
                                "give the directory holding the records' input files",
                                parameter="data")
    groups: dict = {}
    for path, item in items:
        key = (("triad", str(path)) if isinstance(item, TriadCalibration) else
               (item.method, item.date, tuple(item.inputs.items())))
        same = (str(path.resolve()) if isinstance(item, TriadCalibration) else
                (item.serial, item.names, item.estimates.tobytes()))
        groups.setdefault(key, {}).setdefault(same, (path, item))  # a record given twice: once
    sections = []
    for group in groups.values():
        members = list(group.values())
        path, item = members[0]
        if isinstance(item, TriadCalibration):
            sections.append(triad_calibration_section(item, path.name))
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
    rows = [{"parameter": n, "value": float(v), "unit": format_unit(units[n]),
             "meaning": meaning[n[0]]} for n, v in zip(names, cal.vector, strict=True)]
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
