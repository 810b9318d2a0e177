"""Vibrafuge records: files of kind ``vibrafuge`` and their data type :class:`VibrafugeRun`.

A record file (see :mod:`accelcal.io.records`) of kind ``vibrafuge`` holds
one or more test points, each with a static and a vibrating record sampled
at the same rate and of the same length. Columns:

``point`` (-)
    Index of the test point, 0 .. P-1; rows of a point are contiguous.
``t`` (s)
    Sample time from the start of the point's record, ``j / sample_rate_hz``.
``static``, ``vibrating`` (output unit)
    Output at rest (overload only) and while vibrating.

Metadata fields: ``sample_rate_hz``, ``frequency_hz`` (vibration),
``scale_factor`` (nominal K1, output unit per g, to express the VRE in g),
``output_unit``, ``direction`` ([IA, OA, PA], the vibration direction),
``points`` (a list with one object per point: ``overload_g`` as
[IA, OA, PA] and ``amplitude_g``), and the informative ``phase_rad``,
``sampling``, ``noise_g``, ``quantum`` (output unit), and the optional
laboratory fields ``serial``, ``operator``, ``date``, ``local_gravity``
(:mod:`accelcal.io.lab_metadata`; pass them in ``provenance`` to write them)
and ``simulated`` (written as true for a :attr:`VibrafugeRun.simulated` run).

The simulator (:mod:`accelcal.rigs.vibrafuge`) produces a
:class:`VibrafugeRun`; the VRE method
(:func:`accelcal.methods.vre.reduce_run`) reduces one.

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   sec. 2 (static and vibrating records of a vibrafuge test point).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.
"""

import math
import numbers
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import check_lab_metadata
from accelcal.io.records import read_record, write_record
from accelcal.units import OUTPUT_UNITS
from accelcal.validation import shown

KIND = "vibrafuge"
"""Record-file kind of vibrafuge records."""

IMPORT = ImportLayout(reader="read_vibrafuge", time=True, restart="point",
                      states=("output_unit", "sample_rate_hz"))
"""How ``accelcal import`` makes this kind from a recording."""

SAMPLE_RATE_RTOL = 1e-9
"""Relative tolerance for a time column to match ``sample_rate_hz``."""

MAX_MAGNITUDE = 1e9
"""Largest magnitude read for a sample (output unit), an overload or amplitude (g),
a rate or frequency (Hz), a phase (rad), a noise level or quantum, or a scale
factor (output unit per g): far beyond any vibrafuge test, and small enough that
squares and sums of a record stay within the float range. A larger value is a
corrupt cell, not a measurement."""

MIN_SCALE_FACTOR = 1e-9
"""Smallest magnitude of ``scale_factor`` read (output unit per g): dividing by a
smaller one would turn rounding noise into VRE beyond the float range."""


@dataclass(frozen=True)
class VibrafugeRun:
    """Static and vibrating records of one or more vibrafuge test points.

    Attributes
    ----------
    static, vibrating : numpy.ndarray, shape (P, n)
        Output at rest and while vibrating, in ``output_unit``; row ``k`` is
        test point ``k``; sample ``j`` is at ``t = j / sample_rate``.
    overload : numpy.ndarray, shape (P, 3)
        Overload vector of each point in IA, OA, PA, g.
    amplitude : numpy.ndarray, shape (P,)
        Vibration amplitude of each point, g.
    direction : numpy.ndarray, shape (3,)
        Unit vibration direction in IA, OA, PA.
    frequency : float
        Vibration frequency, Hz.
    sample_rate : float
        Sample rate of both records, Hz.
    phase : float
        Vibration phase at ``t = 0``, rad.
    scale_factor : float
        Nominal scale factor K1 (output unit per g) used to express the VRE
        in g.
    output_unit : str
        Unit of the records.
    sampling : str
        ``"integrating"``, ``"point"``, or ``"measured"`` for records read
        from a file of unknown origin.
    noise : float
        Standard deviation of the added noise, g (0: none).
    quantum : float
        Output quantisation step in ``output_unit`` (0: none).
    simulated : bool
        True for records a simulator made (:mod:`accelcal.rigs.vibrafuge`):
        written as the laboratory field ``"simulated": true``, so that
        calibration records made from the file say so.
    """

    static: np.ndarray
    vibrating: np.ndarray
    overload: np.ndarray
    amplitude: np.ndarray
    direction: np.ndarray
    frequency: float
    sample_rate: float
    phase: float = 0.0
    scale_factor: float = 1.0
    output_unit: str = "g"
    sampling: str = "measured"
    noise: float = 0.0
    quantum: float = 0.0
    simulated: bool = False

    @property
    def t(self) -> np.ndarray:
        """Sample times, s (start of each sample interval)."""
        return np.arange(self.static.shape[-1]) / self.sample_rate

    @property
    def points(self) -> int:
        """Number of test points."""
        return self.static.shape[0]


def write_vibrafuge(path, run: VibrafugeRun, *, provenance: dict | None = None) -> None:
    """Write a run as a ``vibrafuge`` record file (atomically).

    Parameters
    ----------
    path : path-like
        File to write.
    run : VibrafugeRun
        The records.
    provenance : dict, optional
        Extra JSON-serialisable metadata (e.g. the simulated model's terms,
        the laboratory fields).
    """
    P, n = run.static.shape
    meta = {
        "units": {"point": "-", "t": "s", "static": run.output_unit,
                  "vibrating": run.output_unit},
        "sample_rate_hz": run.sample_rate,
        "frequency_hz": run.frequency,
        "phase_rad": run.phase,
        "scale_factor": run.scale_factor,
        "output_unit": run.output_unit,
        "direction": [float(x) for x in run.direction],
        "sampling": run.sampling,
        "noise_g": run.noise,
        "quantum": run.quantum,
        "points": [
            {"overload_g": [float(x) for x in b], "amplitude_g": float(a)}
            for b, a in zip(run.overload, run.amplitude, strict=True)
        ],
        **(provenance or {}),
        **({"simulated": True} if run.simulated else {}),
    }
    columns = {
        "point": np.repeat(np.arange(P), n),
        "t": np.tile(np.arange(n) / run.sample_rate, P),
        "static": run.static.reshape(-1),
        "vibrating": run.vibrating.reshape(-1),
    }
    write_record(path, KIND, meta, columns)


def _number(meta, key, path, *, positive=False, nonzero=False) -> float:
    value = meta.get(key)
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise AccelcalError(f"{path}: metadata {key} must be a finite number, got {shown(value)}")
    if positive and value <= 0:
        raise AccelcalError(f"{path}: metadata {key} = {value} must be positive")
    if nonzero and value == 0:
        raise AccelcalError(f"{path}: metadata {key} must be non-zero")
    low = MIN_SCALE_FACTOR if nonzero else 0.0
    if not low <= abs(value) <= MAX_MAGNITUDE:
        raise AccelcalError(f"{path}: metadata {key} = {value:.6g} is beyond any physical value "
                            f"(magnitude {low:g} to {MAX_MAGNITUDE:g}); is the file corrupt?")
    return float(value)


def _vector(value, what, path) -> list[float]:
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        value = [value, 0.0, 0.0]
    ok = (isinstance(value, list) and len(value) == 3
          and all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)
                  for x in value))
    if not ok:
        raise AccelcalError(
            f"{path}: {what} must be 3 finite numbers [IA, OA, PA], got {shown(value)}")
    if max(abs(x) for x in value) > MAX_MAGNITUDE:
        raise AccelcalError(f"{path}: {what} = {shown(value)} is beyond any physical value "
                            f"(components up to {MAX_MAGNITUDE:g}); is the file corrupt?")
    return [float(x) for x in value]


def read_vibrafuge(path) -> VibrafugeRun:
    """Read and validate a ``vibrafuge`` record file.

    Raises
    ------
    AccelcalError
        Naming the file and the field: missing or malformed metadata,
        negative amplitudes, points out of order or of unequal length, or a
        time column whose sample rate differs from ``sample_rate_hz``.
    """
    meta, cols = read_record(
        path, KIND,
        required_metadata=("sample_rate_hz", "frequency_hz", "scale_factor", "output_unit",
                           "direction", "points"),
        required_columns=("point", "t", "static", "vibrating"),
    )
    lab = check_lab_metadata(meta, path)
    fs = _number(meta, "sample_rate_hz", path, positive=True)
    f = _number(meta, "frequency_hz", path, positive=True)
    k1 = _number(meta, "scale_factor", path, nonzero=True)
    unit = meta["output_unit"]
    if unit not in OUTPUT_UNITS:
        raise AccelcalError(
            f"{path}: output_unit {shown(unit)} is not one of {', '.join(OUTPUT_UNITS)}")
    u = np.array(_vector(meta["direction"], "direction", path))
    if not np.linalg.norm(u) > 0:
        raise AccelcalError(f"{path}: direction is the zero vector")
    points = meta["points"]
    if not isinstance(points, list) or not points:
        raise AccelcalError(f"{path}: points must be a non-empty list of test points")
    overload, amplitude = [], []
    for k, p in enumerate(points):
        if not isinstance(p, dict) or "overload_g" not in p or "amplitude_g" not in p:
            raise AccelcalError(f"{path}: points[{k}] needs overload_g and amplitude_g")
        overload.append(_vector(p["overload_g"], f"points[{k}].overload_g", path))
        a = _number(p, "amplitude_g", f"{path}: points[{k}]")
        if a < 0:
            raise AccelcalError(f"{path}: points[{k}].amplitude_g = {a} is negative")
        amplitude.append(a)
    P = len(points)
    idx = cols["point"]
    n_rows = idx.size
    if n_rows % P or not np.array_equal(idx, np.repeat(np.arange(P), n_rows // P)):
        raise AccelcalError(
            f"{path}: column point must run 0..{P - 1} in order, with the same number of "
            "samples for every point (write points of different lengths to separate files)"
        )
    n = n_rows // P
    for name in ("t", "static", "vibrating"):
        big = np.flatnonzero(~(np.abs(cols[name]) <= MAX_MAGNITUDE))
        if big.size:
            raise AccelcalError(
                f"{path}: column {name} row {int(big[0])} = {cols[name][big[0]]:.6g} is beyond "
                f"any physical value (magnitude up to {MAX_MAGNITUDE:g}); is the file corrupt?")
    t = cols["t"].reshape(P, n)
    if n > 1:
        dt = np.diff(t, axis=1)
        stuck = ~(dt > 0)
        if stuck.any():
            k, j = (int(i[0]) for i in np.nonzero(stuck))
            raise AccelcalError(
                f"{path}: column t of point {k} does not increase at row {k * n + j + 1} "
                f"({t[k, j]:.9g} s to {t[k, j + 1]:.9g} s); sample times must increase "
                "at 1/sample_rate_hz"
            )
        bad = ~(np.abs(dt * fs - 1.0) <= SAMPLE_RATE_RTOL)
        if bad.any():
            k = int(np.flatnonzero(bad.any(axis=1))[0])
            raise AccelcalError(
                f"{path}: unequal sample rates: point {k}'s time column steps by "
                f"{dt[k].min():.9g}..{dt[k].max():.9g} s but sample_rate_hz is {fs:g} Hz; "
                "both records must be sampled uniformly at sample_rate_hz"
            )
    return VibrafugeRun(
        static=cols["static"].reshape(P, n), vibrating=cols["vibrating"].reshape(P, n),
        overload=np.array(overload), amplitude=np.array(amplitude),
        direction=u / np.linalg.norm(u), frequency=f, sample_rate=fs,
        phase=_optional(meta, "phase_rad", path), scale_factor=k1, output_unit=unit,
        sampling=str(meta.get("sampling", "measured")),
        noise=_optional(meta, "noise_g", path), quantum=_optional(meta, "quantum", path),
        simulated=lab.simulated,
    )


def _optional(meta, key, path) -> float:
    return _number(meta, key, path) if key in meta else 0.0
