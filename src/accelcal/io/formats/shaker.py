"""Shaker record files (kind ``shaker``): one file per direction angle and amplitude.

The data type :class:`ShakerRecords` (arrays of shape ``(..., m, n)``: ``m``
direction angles of ``n`` samples, plus metadata) and its files: a
directory of one CSV or Parquet record per angle (and amplitude), named by
:func:`record_file_name`, on the shared container of
:mod:`accelcal.io.records`. Metadata fields: ``frequency_hz``,
``sample_rate_hz``, ``angle_deg``, ``amplitude_g``, ``gravity_g``,
``output_unit`` (required), ``scale_factor``, ``axial_sensitivity``,
``sensor``, ``source`` and the laboratory fields of
:mod:`accelcal.io.lab_metadata` (optional; the simulator writes
``"simulated": true``). Columns: ``t``, ``ref``, ``u``
and optionally ``ref_n``, ``ref_ia``, ``u_rest``. The simulation that
produces these records is :mod:`accelcal.rigs.shaker`; the reductions are in
:mod:`accelcal.methods.transverse`.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (5)-(6), Figs. 1-2.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration
   sensitivity (shaker method).
"""

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import check_lab_metadata, read_metadata
from accelcal.io.record_gaps import repair_gaps
from accelcal.io.records import read_record, write_record
from accelcal.validation import shown, shown_path


@dataclass(frozen=True)
class ShakerRecords:
    """Simulated or measured shaker records, one per direction angle.

    Arrays have shape ``(..., m, n)``: leading axes (trials), ``m`` angles,
    ``n`` samples. Optional channels are None when absent.

    Attributes
    ----------
    t : numpy.ndarray
        Sample times, s, shape ``(n,)``.
    theta : numpy.ndarray
        Direction angles, rad, shape ``(m,)``.
    ref : numpy.ndarray
        Reference accelerometer along the vibration axis, g.
    u : numpy.ndarray
        Sensor output while vibrating, ``output_unit``.
    frequency, sample_rate : float
        Hz.
    amplitude : float
        Nominal vibration amplitude A_v, g.
    gravity : float
        Static specific force along the vibration axis, g.
    output_unit : str
        Unit of ``u``.
    scale_factor : float
        Axial scale factor of the sensor (K1 or s_i), output unit per g, when known.
    ref_n, ref_ia : numpy.ndarray or None
        Reference channels measuring the shaker's transverse motion along
        ``e_n`` and along IA, g.
    u_rest : numpy.ndarray or None
        Sensor output at rest (static gravity only) at each angle.
    metadata : dict
        Further description (sensor, settings).
    """

    t: np.ndarray
    theta: np.ndarray
    ref: np.ndarray
    u: np.ndarray
    frequency: float
    sample_rate: float
    amplitude: float
    gravity: float
    output_unit: str
    scale_factor: float | None = None
    ref_n: np.ndarray | None = None
    ref_ia: np.ndarray | None = None
    u_rest: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = np.shape(self.t)[-1]
        m = np.shape(self.theta)[-1]
        for name in ("ref", "u", "ref_n", "ref_ia", "u_rest"):
            arr = getattr(self, name)
            if arr is None:
                continue
            shape = np.shape(arr)
            if len(shape) < 2 or shape[-1] != n or shape[-2] != m:
                raise AccelcalError(
                    f"shaker records: channel {name} has shape {shape}, expected (..., {m}, {n}) "
                    f"for {m} angles of {n} samples; give channels of equal length"
                )


KIND = "shaker"
"""``kind`` of shaker record files (see :mod:`accelcal.io.records`)."""

IMPORT = ImportLayout(reader="read_records", time=True,
                      states=("output_unit", "sample_rate_hz"))
"""How ``accelcal import`` makes this kind from a recording."""

_REQUIRED_META = ("frequency_hz", "sample_rate_hz", "angle_deg", "amplitude_g", "gravity_g",
                  "output_unit")
_OPTIONAL = ("ref_n", "ref_ia", "u_rest")

MAX_MAGNITUDE = 1e9
"""Largest magnitude read for a sample (output unit or g), an amplitude or gravity
(g), a frequency or sample rate (Hz) or a scale factor (output unit per g): far
beyond any shaker test, and small enough that squares and sums of a record stay
within the float range. A larger value is a corrupt cell, not a measurement."""

MIN_SCALE_FACTOR = 1e-9
"""Smallest magnitude of a scale factor read (output unit per g)."""


def _bounded(value, path, what: str, *, low: float = 0.0) -> None:
    """Refuse values whose magnitude exceeds MAX_MAGNITUDE or is below ``low`` (non-zero)."""
    mag = np.abs(np.asarray(value, dtype=float)).reshape(-1)
    ok = (mag <= MAX_MAGNITUDE) & (mag >= low)
    bad = np.flatnonzero(~ok)
    if bad.size:
        where = f" (row {int(bad[0])})" if np.ndim(value) else ""
        raise AccelcalError(
            f"{path}: {what}{where} = {np.asarray(value, float).reshape(-1)[bad[0]]:.6g} is "
            f"beyond any physical value (magnitude {low:g} to {MAX_MAGNITUDE:g}); "
            "is the file corrupt?")


def record_file_name(amplitude: float, angle_deg: float) -> str:
    """File name of one record in a directory: ``shaker_A5g_theta045.00.csv``."""
    return f"shaker_A{amplitude:g}g_theta{angle_deg:06.2f}.csv"


def _record_tables(records: ShakerRecords, extra: dict | None):
    if records.u.ndim != 2:
        raise AccelcalError("only records of shape (angles, samples) can be written to files")
    unit = records.output_unit
    units = {"t": "s", "ref": "g", "u": unit, "ref_n": "g", "ref_ia": "g", "u_rest": unit}
    for j, theta in enumerate(records.theta):
        angle = float(np.rad2deg(theta))
        cols = {"t": records.t, "ref": records.ref[j], "u": records.u[j]}
        for name in _OPTIONAL:
            arr = getattr(records, name)
            if arr is not None:
                cols[name] = arr[j]
        meta = {
            "frequency_hz": records.frequency, "sample_rate_hz": records.sample_rate,
            "angle_deg": angle, "amplitude_g": records.amplitude, "gravity_g": records.gravity,
            "output_unit": unit, "units": {k: units[k] for k in cols},
        }
        if records.scale_factor is not None:
            meta["scale_factor"] = records.scale_factor
        meta.update(records.metadata)
        meta.update(extra or {})
        yield angle, meta, cols


def write_records(records_list, out, *, extra: dict | None = None, suffix: str = ".csv") -> list:
    """Write shaker records, one file per angle (and amplitude).

    Parameters
    ----------
    records_list : ShakerRecords or list of ShakerRecords
        Records of shape ``(m, n)``, e.g. one per amplitude.
    out : path-like
        A directory (created if absent; files named by :func:`record_file_name`)
        or, for exactly one record, a file ending in ``.csv``.
    extra : dict, optional
        Further metadata written into every file (e.g. ``serial``,
        ``operator``, ``date``, ``local_gravity``).
    suffix : {".csv", ".parquet"}
        File type of the records written into a directory.

    Returns
    -------
    list of pathlib.Path
        The files written. A new directory appears whole or not at all.

    References
    ----------
    .. [1] Record format: :mod:`accelcal.io.records`; fields in docs/transverse.md.
    """
    if isinstance(records_list, ShakerRecords):
        records_list = [records_list]
    tables = [(rec.amplitude, *row) for rec in records_list
              for row in _record_tables(rec, extra)]
    out = Path(out)
    if out.suffix.lower() == ".csv":
        if len(tables) != 1:
            raise AccelcalError(
                f"{out} is one file but {len(tables)} records were made (one per angle "
                "and amplitude); give a directory, or one angle and one amplitude",
                parameter="out",
            )
        _, _, meta, cols = tables[0]
        write_record(out, KIND, meta, cols)
        return [out]
    if out.exists() and not out.is_dir():
        raise AccelcalError(f"{out} exists and is not a directory", parameter="out")
    if suffix not in (".csv", ".parquet"):
        raise AccelcalError(f"record file suffix {suffix!r} is not .csv or .parquet",
                            parameter="suffix")
    names = [record_file_name(a, ang).removesuffix(".csv") + suffix for a, ang, _, _ in tables]
    if len(set(names)) != len(names):
        raise AccelcalError("two records would share a file name (repeated angle or amplitude)")
    if out.is_dir():
        for name, (_, _, meta, cols) in zip(names, tables, strict=True):
            write_record(out / name, KIND, meta, cols)
        return [out / n for n in names]
    from accelcal.io.atomic import LIVE, check_output, sweep, temp_name, write_error

    check_output(out)
    sweep(out.parent)
    tmp = out.parent / temp_name(out.name, "", directory=out.parent)
    try:
        os.mkdir(tmp, 0o777)  # the umask applies, as to any new directory
        LIVE.add(tmp)
        for name, (_, _, meta, cols) in zip(names, tables, strict=True):
            write_record(tmp / name, KIND, meta, cols)
        os.replace(tmp, out)
        LIVE.discard(tmp)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        LIVE.discard(tmp)
        raise write_error(out, exc) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        LIVE.discard(tmp)
        raise
    return [out / n for n in names]


def read_records(path) -> list[ShakerRecords]:
    """Read shaker record files: a directory of them or one file.

    Records are grouped by amplitude (one :class:`ShakerRecords` per
    amplitude, angles sorted); within a group every file must share the
    frequency, sample rate, gravity, output unit, channels and time base.

    Raises
    ------
    AccelcalError
        For a missing path, an empty directory, malformed files, channels or
        files of different lengths, or inconsistent metadata (naming the file).

    References
    ----------
    .. [1] Record format: :mod:`accelcal.io.records`; fields in docs/transverse.md.
    """
    path = Path(path)
    if path.is_dir():
        files = sorted([*path.glob("*.csv"), *path.glob("*.parquet")])
        if not files:
            raise AccelcalError(
                f"{shown_path(path)}: no record files (*.csv, *.parquet) in the directory")
    elif path.exists():
        files = [path]
    else:
        raise AccelcalError(f"{shown_path(path)}: no such file or directory")
    groups: dict[float, list] = {}
    for f in files:
        meta, cols = read_record(f, KIND, required_metadata=_REQUIRED_META,
                                 required_columns=("t", "ref", "u"))
        for key in ("frequency_hz", "sample_rate_hz", "angle_deg", "amplitude_g", "gravity_g"):
            if isinstance(meta[key], bool) or not isinstance(meta[key], int | float):
                raise AccelcalError(f"{f}: metadata {key} must be a number")
        if meta["sample_rate_hz"] > 0:  # a gap is refused: the directions share one time axis
            repair_gaps(cols, where=f, interval=1.0 / meta["sample_rate_hz"], what="the record",
                        hint="the sine fits need consecutive samples at sample_rate_hz, and "
                             "every direction the same samples; cut the recording at the gap")
        scale = meta.get("scale_factor")
        if scale is not None and (isinstance(scale, bool) or not isinstance(scale, int | float)
                                  or not np.isfinite(scale) or scale == 0):
            raise AccelcalError(f"{f}: metadata scale_factor must be a finite non-zero number")
        _check_values(f, meta, cols)
        check_lab_metadata(meta, f)
        groups.setdefault(float(meta["amplitude_g"]), []).append((f, meta, cols))
    out = []
    for amp in sorted(groups):
        items = sorted(groups[amp], key=lambda x: float(x[1]["angle_deg"]))
        f0, meta0, cols0 = items[0]
        chans = [c for c in _OPTIONAL if c in cols0]
        for f, meta, cols in items[1:]:
            for key in ("frequency_hz", "sample_rate_hz", "gravity_g", "output_unit"):
                if meta[key] != meta0[key]:
                    raise AccelcalError(
                        f"{f}: {key} = {shown(meta[key])} differs from {shown(meta0[key])} in "
                        f"{f0}; "
                        "records of one amplitude must share it")
            if cols["t"].size != cols0["t"].size:
                raise AccelcalError(
                    f"{f}: {cols['t'].size} samples, but {f0} has {cols0['t'].size}; records "
                    "of one amplitude must have channels of equal length")
            if [c for c in _OPTIONAL if c in cols] != chans:
                raise AccelcalError(f"{f}: channels differ from those of {f0}")
        stack = {c: np.stack([it[2][c] for it in items]) for c in ("ref", "u", *chans)}
        scale = meta0.get("scale_factor")
        out.append(ShakerRecords(
            t=cols0["t"], theta=np.deg2rad([float(it[1]["angle_deg"]) for it in items]),
            ref=stack["ref"], u=stack["u"], frequency=float(meta0["frequency_hz"]),
            sample_rate=float(meta0["sample_rate_hz"]), amplitude=amp,
            gravity=float(meta0["gravity_g"]), output_unit=str(meta0["output_unit"]),
            scale_factor=None if scale is None else float(scale),
            ref_n=stack.get("ref_n"), ref_ia=stack.get("ref_ia"), u_rest=stack.get("u_rest"),
            metadata={k: v for k, v in meta0.items()
                      if k in ("axial_sensitivity", "sensor", "source", "serial",
                               "operator", "date", "local_gravity", "simulated")},
        ))
    return out


def _check_values(f, meta, cols) -> None:
    """Refuse non-physical magnitudes in the metadata and columns of one file."""
    for key in ("frequency_hz", "sample_rate_hz", "amplitude_g", "gravity_g"):
        _bounded(meta[key], f, f"metadata {key}")
    if not -360.0 <= meta["angle_deg"] <= 360.0:
        raise AccelcalError(f"{f}: metadata angle_deg = {meta['angle_deg']:.6g} is not a "
                            "direction within one turn (0 to 360 deg)")
    if meta.get("scale_factor") is not None:
        _bounded(meta["scale_factor"], f, "metadata scale_factor", low=MIN_SCALE_FACTOR)
    table = meta.get("axial_sensitivity")
    for key, value in (table.items() if isinstance(table, dict) else ()):
        if isinstance(value, int | float) and not isinstance(value, bool) and value != 0:
            _bounded(value, f, f"metadata axial_sensitivity.{key}", low=MIN_SCALE_FACTOR)
    for name in ("t", "ref", "u", *_OPTIONAL):
        if name in cols:
            _bounded(cols[name], f, f"column {name}")


def shaker_files(path) -> dict[float, list[Path]]:
    """Shaker record files of a directory (or one file), grouped by amplitude (g).

    The grouping is that of :func:`read_records`, so each amplitude's
    calibration record hashes exactly its own files.
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
