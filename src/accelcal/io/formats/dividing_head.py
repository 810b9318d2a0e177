"""Record files of indexing-head tests (kind ``dividing-head``): :class:`HeadRecord`.

The record's data type (:class:`HeadRecord`), its writer and reader, and
the check of nominal head angles (:func:`check_positions`) that the rig
and the reductions share. Nothing here depends on the methods or the rig:
:meth:`accelcal.methods.dividing_head.HeadData.from_record` turns a record
into reduction data.

A record file (see :mod:`accelcal.io.records`) with columns

* ``angle_deg``: nominal head angle, degrees;
* ``repeat`` (optional): reading index 0, 1, ... when positions are read
  more than once; every repeat covers the same angles;
* one column per sensor (names in ``sensors``): output in ``output_unit``.

and metadata

* ``sensors``: the sensor column names, in mount order;
* ``mount_phases_deg``: each sensor's mount phase, degrees;
* ``nominal_scale_factors``: each sensor's nominal scale factor, output unit per g;
* ``output_unit``: ``V``, ``mV``, ``mA`` or ``g``;
* ``units``: unit of every column;
* optional ``autocollimator_arcsec`` (one reading of the head error per
  angle, in the order of the first repeat) with ``autocollimator_sd_arcsec``;
* optional ``first_harmonic_rad`` ``[d1c, d1s]`` with ``first_harmonic_sd_rad``;
* optional ``serial`` (one per sensor column), ``operator``, ``date`` and
  ``local_gravity`` (:mod:`accelcal.io.lab_metadata`);
* optional ``simulation`` (simulated files): ``models`` (model-file
  objects), ``eta_rad``, ``angle_error_rad`` (applied head errors), ``seed``
  and a ``description``.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
"""

import json
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import check_lab_metadata
from accelcal.io.limits import MAX_JSON_BYTES
from accelcal.io.records import MAX_RECORD_VALUES, read_record, write_record
from accelcal.units import ARCSEC, DEG, OUTPUT_UNITS
from accelcal.validation import is_finite_number, shown, shown_name

KIND = "dividing-head"

IMPORT = ImportLayout(reader="read_head_record", states=("output_unit", "sensors"))
"""How ``accelcal import`` makes this kind from a recording."""

MAX_ANGLE_ERROR_RAD = float(np.radians(1.0))
"""Largest head angle error (and its uncertainty) accepted, rad (1 deg = 3600 arcsec).
Indexing heads are accurate to arcseconds (Dong2014: a few arcsec), and the reductions
linearise in the head error (the second-order term d^2/2 is 1.5e-4 of the output at
1 deg): anything larger is a unit mistake, not a head."""

MAX_OUTPUT = 1e9
"""Largest magnitude of a reading or a nominal scale factor, in the output unit (V, mV,
mA or g): a million times any accelerometer's output, and far below where squares and
products of readings overflow (1e154)."""

METADATA_BYTES_PER_VALUE = 26
"""Bytes of JSON a float takes in the metadata line (17 significant digits, exponent,
separator): to tell before simulating whether per-position metadata fits."""

_KNOWN = {
    "format_version", "kind", "units", "sensors", "mount_phases_deg", "nominal_scale_factors",
    "output_unit", "autocollimator_arcsec", "autocollimator_sd_arcsec", "first_harmonic_rad",
    "first_harmonic_sd_rad", "simulation", "serial", "operator", "date", "local_gravity",
    "simulated", "provenance",
}


@dataclass(frozen=True)
class HeadRecord:
    """Contents of a ``dividing-head`` record file.

    Attributes
    ----------
    positions : numpy.ndarray
        Nominal head angles, rad, shape ``(n,)``.
    outputs : numpy.ndarray
        Outputs, shape ``(R, K, n)`` (R repeats).
    mounts : numpy.ndarray
        Mount phases, rad, ``(K,)``.
    sensors : tuple of str
        Sensor column names.
    output_unit : str
        Unit of the outputs.
    nominal_scale_factors : numpy.ndarray
        Output unit per g, ``(K,)``.
    autocollimator : numpy.ndarray or None
        Head error readings, rad, ``(n,)``.
    autocollimator_sd : float or None
        Their standard uncertainty, rad.
    first_harmonic : numpy.ndarray or None
        Measured (d1c, d1s), rad.
    first_harmonic_sd : float
        Its standard uncertainty, rad.
    simulation : dict or None
        Truth of a simulated file.
    repairs : dict or None
        What the reader left out (incomplete repeats, ``--gaps split``), as
        :meth:`accelcal.io.recordings.repairs.Repairs.to_dict`.
    """

    positions: np.ndarray
    outputs: np.ndarray
    mounts: np.ndarray
    sensors: tuple
    output_unit: str
    nominal_scale_factors: np.ndarray
    autocollimator: np.ndarray | None = None
    autocollimator_sd: float | None = None
    first_harmonic: np.ndarray | None = None
    first_harmonic_sd: float = 0.0
    simulation: dict | None = None
    repairs: dict | None = None

    def true_models(self):
        """The simulated truth as ErrorModels (None for measured files)."""
        if not self.simulation:
            return None
        from accelcal.model import ErrorModel

        return tuple(ErrorModel.from_json(json.dumps(m), source="record simulation.models")
                     for m in self.simulation["models"])


def write_head_record(
    path,
    positions,
    outputs,
    mounts,
    *,
    sensors=None,
    output_unit: str = "V",
    nominal_scale_factors=None,
    autocollimator=None,
    autocollimator_sd=None,
    first_harmonic=None,
    first_harmonic_sd: float = 0.0,
    simulation: dict | None = None,
    lab: dict | None = None,
) -> None:
    """Write a ``dividing-head`` record atomically.

    Parameters
    ----------
    path : path-like
        File to write.
    positions : array_like
        Nominal head angles, rad, ``(n,)``.
    outputs : array_like
        ``(K, n)`` or ``(R, K, n)`` outputs in ``output_unit``.
    mounts : array_like
        Mount phases, rad, ``(K,)``.
    sensors : sequence of str, optional
        Column names (default U1, U2, ...).
    output_unit : str
        Unit of the outputs.
    nominal_scale_factors : array_like, optional
        Output unit per g (default 1 each).
    autocollimator, autocollimator_sd : array_like, float, optional
        Head error readings at each position and their uncertainty, rad.
    first_harmonic, first_harmonic_sd : (float, float), float, optional
        Measured first harmonic of the head error and its uncertainty, rad.
    simulation : dict, optional
        Truth of a simulated run (JSON-serialisable).
    lab : dict, optional
        Laboratory metadata (``serial`` list, ``operator``, ``date``,
        ``local_gravity``; :mod:`accelcal.io.lab_metadata`).
    """
    alpha = np.asarray(positions, dtype=float).reshape(-1)
    check_positions(alpha)
    u = np.asarray(outputs, dtype=float)
    u = u[None] if u.ndim == 2 else u
    if u.ndim != 3 or u.shape[-1] != alpha.size:
        raise AccelcalError(f"outputs of shape {u.shape} do not match {alpha.size} positions")
    r, k, n = u.shape
    names = list(sensors) if sensors is not None else [f"U{i + 1}" for i in range(k)]
    phi = np.asarray(mounts, dtype=float).reshape(-1)
    if len(names) != k or phi.size != k:
        raise AccelcalError(f"{k} sensor columns need {k} names and {k} mount phases")
    if output_unit not in OUTPUT_UNITS:
        raise AccelcalError(
            f"output unit {shown(output_unit)} is not one of {', '.join(OUTPUT_UNITS)}")
    ksf = np.ones(k) if nominal_scale_factors is None else \
        np.asarray(nominal_scale_factors, dtype=float).reshape(-1)
    columns = {"angle_deg": np.tile(alpha / DEG, r)}
    units = {"angle_deg": "deg"}
    if r > 1:
        columns["repeat"] = np.repeat(np.arange(r), n)
        units["repeat"] = "1"
    for i, name in enumerate(names):
        columns[name] = u[:, i, :].reshape(-1)
        units[name] = output_unit
    meta = {
        "units": units,
        "sensors": names,
        "mount_phases_deg": (phi / DEG).tolist(),
        "nominal_scale_factors": ksf.tolist(),
        "output_unit": output_unit,
    }
    if autocollimator is not None:
        meta["autocollimator_arcsec"] = (np.asarray(autocollimator, float) / ARCSEC).tolist()
        meta["autocollimator_sd_arcsec"] = float(autocollimator_sd) / ARCSEC
    if first_harmonic is not None:
        meta["first_harmonic_rad"] = [float(v) for v in first_harmonic]
        meta["first_harmonic_sd_rad"] = float(first_harmonic_sd)
    if simulation is not None:
        meta["simulation"] = simulation
    if lab:
        check_lab_metadata(lab, path, k)
        meta.update(lab)
    write_record(path, KIND, meta, columns)


def read_head_record(path, *, gaps: str = "refuse", max_fill: int = 5) -> HeadRecord:
    """Read and validate a ``dividing-head`` record.

    A record has no time column: its gaps are missing readings. A repeat
    (after the first, which names the positions) that lacks some of the
    positions is refused (``gaps="refuse"``) or, with ``"split"``, left out
    (``repairs``); never filled (a reading at a head position is no
    interpolation of its neighbours'). ``max_fill`` is checked, not used.

    Raises
    ------
    AccelcalError
        Naming the file and the problem: unknown metadata keys, sensor names
        that do not match the columns, a wrong number of mount phases or
        scale factors, duplicated angles, incomplete repeats, NaN readings.
    """
    from accelcal.io.record_gaps import check_gap_options, finding

    check_gap_options(gaps, max_fill)
    meta, cols = read_record(
        path, KIND, required_metadata=("sensors", "mount_phases_deg", "output_unit"),
        required_columns=("angle_deg",),
    )
    unknown = sorted(set(meta) - _KNOWN)
    if unknown:
        raise AccelcalError(
            f"{path}: unknown metadata field(s) {shown_name(', '.join(unknown), 200)}")
    sensors = meta["sensors"]
    if not isinstance(sensors, list) or not sensors or not all(isinstance(s, str) for s in sensors):
        raise AccelcalError(f"{path}: metadata 'sensors' must be a non-empty list of column names")
    missing = [s for s in sensors if s not in cols]
    extra = [c for c in cols if c not in ("angle_deg", "repeat", *sensors)]
    if missing or extra:
        raise AccelcalError(
            f"{path}: sensor columns do not match metadata 'sensors' "
            f"(missing {shown_name(', '.join(missing), 200) or 'none'}, "
            f"unexpected {shown_name(', '.join(extra), 200) or 'none'})"
        )
    k = len(sensors)
    check_lab_metadata(meta, path, k)
    phases = _number_list(meta["mount_phases_deg"], path, "mount_phases_deg")
    if len(phases) != k:
        raise AccelcalError(
            f"{path}: {len(phases)} mount phases for {k} sensor columns "
            f"({shown_name(', '.join(sensors), 200)}); "
            "give one mount phase per sensor column"
        )
    ksf = _number_list(meta.get("nominal_scale_factors", [1.0] * k), path,
                       "nominal_scale_factors")
    if len(ksf) != k:
        raise AccelcalError(f"{path}: {len(ksf)} nominal scale factors for {k} sensors")
    unit = meta["output_unit"]
    if unit not in OUTPUT_UNITS:
        raise AccelcalError(
            f"{path}: output_unit {shown(unit)} is not one of {', '.join(OUTPUT_UNITS)}")
    angle = cols["angle_deg"] * DEG
    rep = cols.get("repeat", np.zeros(angle.size))
    if not np.array_equal(rep, np.round(rep)) or rep.min() < 0:
        raise AccelcalError(f"{path}: column 'repeat' must hold integers 0, 1, 2, ...")
    reps = np.unique(rep)
    if not np.array_equal(reps, np.arange(reps.size)):
        raise AccelcalError(f"{path}: repeats must be numbered 0, 1, ... without gaps")
    for s_name in sensors:
        big = np.abs(cols[s_name]) > MAX_OUTPUT
        if big.any():
            raise AccelcalError(
                f"{path}: column {shown(s_name)} row {int(np.argmax(big)) + 1} holds "
                f"{cols[s_name][big][0]:.3g}, beyond +-{MAX_OUTPUT:g} {unit}: not a reading; "
                "check the value and the output unit")
    if max((abs(v) for v in ksf), default=0.0) > MAX_OUTPUT or 0.0 in ksf:
        raise AccelcalError(f"{path}: nominal_scale_factors must be non-zero and within "
                            f"+-{MAX_OUTPUT:g} {unit}/g")
    first = angle[rep == 0]
    try:
        check_positions(first, what=f"angles of {path}")
    except AccelcalError as exc:
        raise AccelcalError(str(exc)) from None
    n = first.size
    outputs = np.empty((reps.size, k, n))
    order0 = np.argsort(np.mod(first, 2 * np.pi))
    dropped = []
    for r in reps.astype(int):
        sel = rep == r
        ang = angle[sel]
        if ang.size != n or not np.allclose(np.sort(np.mod(ang, 2 * np.pi)),
                                            np.mod(first, 2 * np.pi)[order0], atol=1e-9):
            if _incomplete(ang, first) and gaps == "split":
                dropped.append((r, int(np.flatnonzero(sel)[0]) + 1, n - ang.size))
                continue
            raise AccelcalError(
                f"{path}: repeat {r} does not cover the same {n} angles as repeat 0"
                + (f" ({n - ang.size} missing); give --gaps split to leave incomplete "
                   "repeats out (a reading is never filled)" if _incomplete(ang, first)
                   else ""))
        check_positions(ang, what=f"angles of repeat {r} in {path}")
        # map repeat r's rows onto repeat 0's order
        idx = np.argsort(np.mod(ang, 2 * np.pi))[np.argsort(order0)]
        for i, s in enumerate(sensors):
            outputs[r, i] = cols[s][sel][idx]
    repairs = None
    if dropped:
        repairs = {"found": [finding("incomplete repeats (positions missing)",
                                     "left out (split)", [row for _, row, _ in dropped])]}
        outputs = np.delete(outputs, [r for r, _, _ in dropped], axis=0)
    ac = ac_sd = None
    if "autocollimator_arcsec" in meta:
        ac = np.asarray(_number_list(meta["autocollimator_arcsec"], path,
                                     "autocollimator_arcsec")) * ARCSEC
        if ac.size != n:
            raise AccelcalError(f"{path}: {ac.size} autocollimator readings for {n} positions")
        if "autocollimator_sd_arcsec" not in meta:
            raise AccelcalError(f"{path}: autocollimator readings need autocollimator_sd_arcsec")
        ac_sd = float(_number_list([meta["autocollimator_sd_arcsec"]], path,
                                   "autocollimator_sd_arcsec")[0]) * ARCSEC
        _check_angles(np.abs(ac), path, "autocollimator_arcsec")
        if not ac_sd > 0:
            raise AccelcalError(f"{path}: autocollimator_sd_arcsec must be > 0")
        _check_angles([ac_sd], path, "autocollimator_sd_arcsec")
    h1 = None
    h1_sd = 0.0
    if "first_harmonic_rad" in meta:
        h1 = np.asarray(_number_list(meta["first_harmonic_rad"], path, "first_harmonic_rad"))
        if h1.size != 2:
            raise AccelcalError(f"{path}: first_harmonic_rad must be [d1c, d1s]")
        h1_sd = float(_number_list([meta.get("first_harmonic_sd_rad", 0.0)], path,
                                   "first_harmonic_sd_rad")[0])
        if h1_sd < 0:
            raise AccelcalError(f"{path}: first_harmonic_sd_rad must be >= 0")
        _check_angles([float(np.hypot(*h1)), h1_sd], path,
                      "first_harmonic_rad and first_harmonic_sd_rad")
    sim = meta.get("simulation")
    if sim is not None and (not isinstance(sim, dict) or "models" not in sim):
        raise AccelcalError(f"{path}: metadata 'simulation' must be an object with 'models'")
    return HeadRecord(first, outputs, np.asarray(phases) * DEG, tuple(sensors), unit,
                      np.asarray(ksf), ac, ac_sd, h1, h1_sd, sim, repairs)


def _incomplete(angles: np.ndarray, first: np.ndarray) -> bool:
    """Whether ``angles`` are some of the positions ``first``, distinct, and fewer."""
    wrap = np.mod(first, 2 * np.pi)
    mine = np.mod(angles, 2 * np.pi)
    near = np.abs(mine[:, None] - wrap[None, :]) < 1e-9
    return bool(mine.size < wrap.size and near.any(axis=1).all()
                and (near.sum(axis=0) <= 1).all())


def _check_angles(values, path, field) -> None:
    """Refuse head-error angles beyond :data:`MAX_ANGLE_ERROR_RAD` (rad) in metadata ``field``."""
    worst = float(np.max(values, initial=0.0))
    if worst > MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(
            f"{path}: metadata '{field}' holds {worst:.3g} rad, beyond 1 deg: not an indexing "
            "head's error or its uncertainty (a few arcsec); check the value and its unit")


def check_record_size(n: int, k: int, repeats: int = 1, *, per_position: int = 0) -> None:
    """Refuse a record of ``repeats x n`` rows and ``k`` sensors that could not be read back.

    Parameters
    ----------
    n, k, repeats : int
        Positions, sensors, readings per position.
    per_position : int
        Metadata arrays with one value per position (simulated head errors,
        autocollimator readings).

    Raises
    ------
    AccelcalError
        When the file would hold more than
        :data:`~accelcal.io.records.MAX_RECORD_VALUES` values, or its metadata
        line more than :data:`~accelcal.io.limits.MAX_JSON_BYTES`.
    """
    values = float(n) * repeats * (k + 1 + (repeats > 1))
    if values > MAX_RECORD_VALUES:
        raise AccelcalError(
            f"a record of {n} positions x {repeats} repeat(s) x {k} sensors holds {values:.3g} "
            f"values, more than the {MAX_RECORD_VALUES:g} a record file may hold",
            parameter="positions")
    meta = float(n) * per_position * METADATA_BYTES_PER_VALUE
    if meta > MAX_JSON_BYTES:
        most = MAX_JSON_BYTES // (per_position * METADATA_BYTES_PER_VALUE)
        raise AccelcalError(
            f"a record of {n} positions carries about {meta / 2**20:.3g} MiB of per-position "
            f"metadata, more than the {MAX_JSON_BYTES / 2**20:g} MiB a record's metadata may "
            f"hold; give at most about {most} positions", parameter="positions")


def _number_list(value, path, field) -> list[float]:
    if not isinstance(value, list) or not all(is_finite_number(v) for v in value):
        raise AccelcalError(f"{path}: metadata '{field}' must be a list of finite numbers")
    return [float(v) for v in value]


def check_positions(alpha: np.ndarray, what: str = "positions") -> None:
    """Refuse empty, non-finite or duplicated (modulo 2 pi) nominal angles."""
    if alpha.size == 0:
        raise AccelcalError(f"no {what} given")
    if not np.isfinite(alpha).all():
        raise AccelcalError(f"{what} contain NaN or inf; give finite angles")
    wrapped = np.sort(np.mod(alpha, 2 * np.pi))
    gaps = np.diff(np.concatenate([wrapped, wrapped[:1] + 2 * np.pi]))
    if alpha.size > 1 and gaps.min() < 1e-9:
        i = int(np.argmin(gaps))
        raise AccelcalError(
            f"{what} repeat the angle {np.degrees(wrapped[i]):.9g} deg (modulo 360); "
            "each position must be given once (put repeated readings in the repeat column)"
        )
