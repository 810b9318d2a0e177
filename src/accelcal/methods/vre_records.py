"""Vibrafuge records: files of kind ``vibrafuge`` and their reduction to VRE.

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
(:mod:`accelcal.io.lab_metadata`; pass them in ``provenance`` to write them).

The VRE of a point is ``(mean_vibrating - mean_static) / scale_factor``,
both means over whole periods of the vibration (the record need not start
at phase zero; the partial period at the end is left out), with standard
uncertainty ``sqrt(u_v^2 + u_s^2) / |scale_factor|`` from each record's
residual noise after removing the periodic signal by synchronous averaging
(all harmonics, which the asymmetry term has), or after removing harmonics
0..8 when the span holds fewer than two repeats of the sampled phases
(:func:`accelcal.signal.periods.whole_period_mean`).

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   sec. 2 (VRE as the difference of whole-period means).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.
"""

import math
import numbers
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.lab_metadata import check_lab_metadata
from accelcal.io.records import read_record, write_record
from accelcal.rigs.vibrafuge import VibrafugeRun
from accelcal.signal.periods import whole_period_mean
from accelcal.units import OUTPUT_UNITS

KIND = "vibrafuge"
"""Record-file kind of vibrafuge records."""

SAMPLE_RATE_RTOL = 1e-9
"""Relative tolerance for a time column to match ``sample_rate_hz``."""

HARMONICS = 8
"""Harmonics of the vibration removed before estimating the noise level when
the synchronous estimate is not available. The asymmetry term has harmonics
of every order; leaving some in makes the uncertainty conservative, never
biases the mean."""


@dataclass(frozen=True)
class VreMeasurement:
    """VRE of each test point of a run, with standard uncertainty.

    Attributes
    ----------
    overload : numpy.ndarray, shape (P, 3)
        Overload vectors, g.
    amplitude : numpy.ndarray, shape (P,)
        Vibration amplitudes, g.
    direction : numpy.ndarray, shape (3,)
        Vibration direction.
    vre : numpy.ndarray, shape (P,)
        Measured VRE, g.
    uncertainty : numpy.ndarray, shape (P,)
        Standard uncertainty of the VRE from the records' noise, g.
    static_mean, vibrating_mean : numpy.ndarray, shape (P,)
        Whole-period means, output unit.
    periods, samples, discarded : int
        Whole periods and samples used, samples left out at the end.
    """

    overload: np.ndarray
    amplitude: np.ndarray
    direction: np.ndarray
    vre: np.ndarray
    uncertainty: np.ndarray
    static_mean: np.ndarray
    vibrating_mean: np.ndarray
    periods: int
    samples: int
    discarded: int

    def rows(self) -> list[dict]:
        """One dict per point (for tables and CSV/JSON output)."""
        return [
            {"point": k, "overload_g": float(b[0]), "overload_oa_g": float(b[1]),
             "overload_pa_g": float(b[2]), "amplitude_g": float(a), "vre_g": float(v),
             "u_vre_g": float(u)}
            for k, (b, a, v, u) in enumerate(
                zip(self.overload, self.amplitude, self.vre, self.uncertainty, strict=True))
        ]


def reduce_run(run: VibrafugeRun, *, harmonics: int = HARMONICS) -> VreMeasurement:
    """Reduce static and vibrating records to VRE with standard uncertainty.

    Parameters
    ----------
    run : VibrafugeRun
        Records of one or more points (simulated or read from a file).
    harmonics : int
        Harmonics of the vibration frequency removed before estimating the
        noise (affects the uncertainty only).

    Returns
    -------
    VreMeasurement

    Raises
    ------
    AccelcalError
        For records shorter than one period, or without a whole-period span.

    References
    ----------
    .. [1] Guan2021, sec. 2: VRE = whole-period mean vibrating minus static.
    """
    fs, f = run.sample_rate, run.frequency
    vib = whole_period_mean(run.vibrating, fs, f, harmonics=harmonics, what="vibrating record")
    sta = whole_period_mean(run.static, fs, f, harmonics=harmonics, what="static record")
    k1 = run.scale_factor
    vre = (np.atleast_1d(vib.mean) - np.atleast_1d(sta.mean)) / k1  # Eq. (9)/(21) [Guan2021]
    u = np.hypot(np.atleast_1d(vib.std), np.atleast_1d(sta.std)) / abs(k1)
    return VreMeasurement(
        overload=run.overload, amplitude=run.amplitude, direction=run.direction, vre=vre,
        uncertainty=u, static_mean=np.atleast_1d(sta.mean), vibrating_mean=np.atleast_1d(vib.mean),
        periods=vib.periods, samples=vib.samples, discarded=vib.discarded,
    )


def write_vibrafuge(path, run: VibrafugeRun, *, provenance: dict | None = None) -> None:
    """Write a run as a ``vibrafuge`` record file (atomically).

    Parameters
    ----------
    path : path-like
        File to write.
    run : VibrafugeRun
        The records.
    provenance : dict, optional
        Extra JSON-serialisable metadata (e.g. the simulated model's terms).
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
        raise AccelcalError(f"{path}: metadata {key} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise AccelcalError(f"{path}: metadata {key} = {value} must be positive")
    if nonzero and value == 0:
        raise AccelcalError(f"{path}: metadata {key} must be non-zero")
    return float(value)


def _vector(value, what, path) -> list[float]:
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        value = [value, 0.0, 0.0]
    ok = (isinstance(value, list) and len(value) == 3
          and all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)
                  for x in value))
    if not ok:
        raise AccelcalError(f"{path}: {what} must be 3 finite numbers [IA, OA, PA], got {value!r}")
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
    check_lab_metadata(meta, path)
    fs = _number(meta, "sample_rate_hz", path, positive=True)
    f = _number(meta, "frequency_hz", path, positive=True)
    k1 = _number(meta, "scale_factor", path, nonzero=True)
    unit = meta["output_unit"]
    if unit not in OUTPUT_UNITS:
        raise AccelcalError(f"{path}: output_unit {unit!r} is not one of {', '.join(OUTPUT_UNITS)}")
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
    t = cols["t"].reshape(P, n)
    if n > 1:
        dt = np.diff(t, axis=1)
        rate = 1.0 / dt
        bad = np.abs(rate - fs) > SAMPLE_RATE_RTOL * fs
        if bad.any():
            k = int(np.flatnonzero(bad.any(axis=1))[0])
            lo, hi = rate[k].min(), rate[k].max()
            raise AccelcalError(
                f"{path}: unequal sample rates: point {k}'s time column is sampled at "
                f"{lo:.9g}..{hi:.9g} Hz but sample_rate_hz is {fs:g} Hz; both records must "
                "be sampled uniformly at sample_rate_hz"
            )
    return VibrafugeRun(
        static=cols["static"].reshape(P, n), vibrating=cols["vibrating"].reshape(P, n),
        overload=np.array(overload), amplitude=np.array(amplitude),
        direction=u / np.linalg.norm(u), frequency=f, sample_rate=fs,
        phase=_optional(meta, "phase_rad", path), scale_factor=k1, output_unit=unit,
        sampling=str(meta.get("sampling", "measured")),
        noise=_optional(meta, "noise_g", path), quantum=_optional(meta, "quantum", path),
    )


def _optional(meta, key, path) -> float:
    return _number(meta, key, path) if key in meta else 0.0
