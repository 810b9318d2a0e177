"""Estimators of the transverse sensitivity s_T(theta) from shaker records.

Each record (one direction angle) is reduced by a named amplitude
estimator (``peak``, ``half-p2p``, ``fundamental``; see
:mod:`accelcal.methods.transverse.theory`) to s_T and its relative value
s_T / s_I; :func:`sweep` simulates the test on the shaker rig and reduces
it, over amplitudes.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (11)-(12), (17)-(18), (21)-(23).
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration sensitivity.
.. [IEEE1057] IEEE Std 1057-2017, secs. 4.1.3.1 and 4.1.3.3 (sine fits).
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.shaker import MAX_MAGNITUDE, MIN_SCALE_FACTOR, ShakerRecords
from accelcal.methods.transverse.theory import (
    axial_sensitivity,
    check_axial,
    check_estimator,
)
from accelcal.rigs.shaker import ShakerRig
from accelcal.signal.periods import whole_period_samples
from accelcal.signal.sinefit import HarmonicFit

PEAK_COVERAGE = 1.0
"""Extra standard deviations added to the expected extreme of the noise in
the peak and half-p2p uncertainty bound (see :func:`estimate_sT`)."""


@dataclass(frozen=True)
class TransverseSweep:
    """Transverse sensitivity against direction angle for one amplitude.

    Attributes
    ----------
    estimator : str
        Amplitude estimator (see :data:`ESTIMATORS`).
    amplitude : float
        Nominal vibration amplitude A_v, g.
    theta : numpy.ndarray
        Direction angles, rad, shape ``(m,)``.
    sT : numpy.ndarray
        Transverse sensitivity, output unit per g, shape ``(..., m)``.
    sT_std : numpy.ndarray
        Stated uncertainty of ``sT``: a standard uncertainty for
        ``fundamental``; for ``peak`` and ``half-p2p`` a bound on the noise's
        contribution (expected extreme of the noise plus one standard deviation).
    s_I : float
        Axial sensitivity used for the relative value, output unit per g.
    axial : str
        Its definition (see :data:`AXIAL_DEFINITIONS`).
    unit : str
        Output unit.
    gravity : float
        Static gravity along the vibration axis, g.
    signed : numpy.ndarray or None
        Signed w response ``Re(P_u / P_ref)`` (``fundamental`` only).
    dc, p2w : numpy.ndarray or None
        DC level and 2w phasor of the output relative to ``P_ref^2`` (complex).
    notes : tuple of str
        Caveats and settings of the reduction.

    References
    ----------
    .. [1] GuanTang, eqs. (12), (18), (22)-(23); ISO 16063-31.
    """

    estimator: str
    amplitude: float
    theta: np.ndarray
    sT: np.ndarray
    sT_std: np.ndarray
    s_I: float
    axial: str
    unit: str
    gravity: float = 0.0
    signed: np.ndarray | None = None
    dc: np.ndarray | None = None
    p2w: np.ndarray | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def sT_rel(self) -> np.ndarray:
        """Relative transverse sensitivity s_T / s_I; Eq. (23) [GuanTang]."""
        return self.sT / self.s_I

    def summary(self) -> dict:
        """S_Tmax, theta_max, S_Tmin, theta_min (deg) and the number of local maxima."""
        return {"estimator": self.estimator, "amplitude_g": self.amplitude,
                **summarize(self.theta, self.sT, self.s_I)}

    def rows(self) -> list[dict]:
        """One row per angle: amplitude_g, angle_deg, sT, sT_rel."""
        return [
            {"amplitude_g": float(self.amplitude), "angle_deg": float(d), "sT": float(s),
             "sT_rel": float(r)}
            for d, s, r in zip(np.rad2deg(self.theta), self.sT, self.sT_rel, strict=True)
        ]


def summarize(theta, sT, s_I: float) -> dict:
    """Extremes of s_T over the angle grid and the number of local maxima.

    On a uniform grid covering the full turn the angles are treated as
    circular; otherwise the end points count as maxima only if above their
    single neighbour.

    References
    ----------
    .. [1] GuanTang, section 4 (S_Tmax, S_Tmin and their direction angles).
    """
    theta = np.asarray(theta, float)
    sT = np.asarray(sT, float)
    order = np.argsort(np.mod(theta, 2 * np.pi))
    th, s = np.mod(theta, 2 * np.pi)[order], sT[order]
    # ties within rounding (a symmetric curve) resolve to the smallest angle
    span = max(float(np.ptp(s)), float(np.max(np.abs(s))) * 1e-300)
    imax = int(np.flatnonzero(s >= s.max() - 1e-9 * span)[0])
    imin = int(np.flatnonzero(s <= s.min() + 1e-9 * span)[0])
    steps = np.diff(np.append(th, th[0] + 2 * np.pi))
    circular = s.size >= 3 and np.allclose(steps, steps[0], rtol=1e-9, atol=1e-12)
    if circular:
        prev, nxt = np.roll(s, 1), np.roll(s, -1)
    else:
        prev = np.concatenate([[-np.inf], s[:-1]])
        nxt = np.concatenate([s[1:], [-np.inf]])
    maxima = int(np.count_nonzero((s > prev) & (s >= nxt)))
    return {
        "S_Tmax": float(s[imax]), "theta_max_deg": float(np.rad2deg(th[imax])),
        "S_Tmin": float(s[imin]), "theta_min_deg": float(np.rad2deg(th[imin])),
        "S_Tmax_rel": float(s[imax] / s_I), "S_Tmin_rel": float(s[imin] / s_I),
        "local_maxima": maxima,
    }


def record_phasors(records: ShakerRecords, harmonics: int = 2) -> dict:
    """Harmonic fits (DC, w, 2w) of every channel of the records.

    Returns
    -------
    dict
        Channel name -> :class:`~accelcal.signal.sinefit.HarmonicResult`.

    Raises
    ------
    AccelcalError
        If the records are shorter than a period or the reference amplitude is
        zero (not distinguishable from its noise).

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1; GuanTang, eq. (11) (A_T from the reference).
    """
    n = records.t.shape[-1]
    t0 = float(records.t[0]) if n else 0.0
    fit = HarmonicFit(n, records.sample_rate, records.frequency, harmonics=harmonics, t0=t0,
                      what="shaker record")
    out = {}
    for name in ("ref", "u", "ref_n", "ref_ia", "u_rest"):
        arr = getattr(records, name)
        if arr is not None:
            out[name] = fit(arr)
    ref = out["ref"]
    amp = ref.amplitude
    tiny = np.maximum(10 * ref.amplitude_std, 1e-12 * np.maximum(np.abs(ref.dc), 1.0))
    if np.any(~(amp > tiny)):
        raise AccelcalError(
            "shaker record: the reference amplitude is zero (or below ten times its noise); "
            "check the reference channel and the vibration amplitude"
        )
    return out


def w_ratio(ph: dict, scale_factor: float | None = None) -> np.ndarray:
    """The output's w phasor over the reference's, ``P_u / P_ref`` (complex, per angle).

    With ``scale_factor`` (K1, output unit per g) and a measured motion
    along IA (``ph["ref_ia"]``), ``K1 P_ia`` is subtracted from ``P_u``
    first: the IA motion enters the output with the coefficient 1 times K1.
    ``|w_ratio|`` is the ``fundamental`` s_T.

    Parameters
    ----------
    ph : dict
        :func:`record_phasors` of the records.
    scale_factor : float, optional
        K1; without it nothing is subtracted.

    References
    ----------
    .. [1] GuanTang, eqs. (11)-(12); docs/domain.md section 3.
    """
    p_u = ph["u"].phasors[..., 0]
    if scale_factor is not None and "ref_ia" in ph:
        p_u = p_u - scale_factor * ph["ref_ia"].phasors[..., 0]
    return p_u / ph["ref"].phasors[..., 0]


def records_axial_sensitivity(records: ShakerRecords, axial: str = "eq20") -> float | None:
    """The axial sensitivity ``axial`` that the records' metadata give (None without one).

    Parameters
    ----------
    records : ShakerRecords
        Records whose metadata may hold ``axial_sensitivity``
        (``{"eq20": ..., "symmetric": ...}``).
    axial : {"eq20", "symmetric"}
        Its definition (:data:`~accelcal.methods.transverse.theory.AXIAL_DEFINITIONS`).

    References
    ----------
    .. [1] GuanTang, eqs. (19)-(20), (25).
    """
    check_axial(axial)
    table = records.metadata.get("axial_sensitivity")
    value = table.get(axial) if isinstance(table, dict) else None
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
        raise AccelcalError(f"the records' metadata axial_sensitivity {axial} must be a finite "
                            "number (output unit per g)")
    return float(value)


def with_fitted_frequency(records: ShakerRecords) -> ShakerRecords:
    """The records with their frequency replaced by a four-parameter sine fit.

    The frequency of each reference record is fitted (IEEE 1057 four-parameter
    fit, starting from the records' nominal frequency) and their mean is used
    for every channel, so the later three-parameter fits are at the frequency
    actually present.

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.3.
    """
    from dataclasses import replace

    from accelcal.signal.sinefit import sine_fit4

    fit = sine_fit4(records.ref, records.sample_rate, records.frequency,
                    t0=float(records.t[0]))
    return replace(records, frequency=float(np.mean(fit.frequency)))


def estimate_sT(records: ShakerRecords, estimator: str, *, s_I: float, axial: str = "eq20",
                separate: bool = True) -> TransverseSweep:
    """Transverse sensitivity from shaker records with a named estimator.

    Parameters
    ----------
    records : ShakerRecords
        Records of shape ``(..., m, n)``.
    estimator : {"peak", "half-p2p", "fundamental"}
    s_I : float
        Axial sensitivity, output unit per g (for the relative values).
    axial : str
        Name of its definition, carried into the result.
    separate : bool
        For ``fundamental``: subtract ``scale_factor * P_ia`` when the
        records carry the shaker's transverse motion along IA (``ref_ia``).

    Returns
    -------
    TransverseSweep

    Notes
    -----
    ``peak`` and ``half-p2p`` use the longest whole-period span of each
    record and divide by the reference amplitude from a sine fit. Their
    stated uncertainty is ``s_u (sqrt(2 ln 2M) + 1) / A``: ``s_u`` is the
    residual standard deviation of the output after removing DC, w and 2w,
    ``M`` the samples used; the noise cannot move an extreme by more than the
    largest noise sample, whose expectation is about ``s_u sqrt(2 ln 2M)``.
    ``fundamental`` states a standard uncertainty from the sine fits.

    References
    ----------
    .. [1] GuanTang, eqs. (11)-(12), (17)-(18), (21)-(23); IEEE Std 1057-2017.
    """
    check_estimator(estimator)
    if not MIN_SCALE_FACTOR <= abs(s_I) <= MAX_MAGNITUDE:
        raise AccelcalError(
            f"axial sensitivity {s_I:g} is not that of an accelerometer (magnitude "
            f"{MIN_SCALE_FACTOR:g} to {MAX_MAGNITUDE:g} output unit per g)")
    check_axial(axial)
    ph = record_phasors(records)
    p_ref = ph["ref"].phasors[..., 0]
    a_ref = np.abs(p_ref)
    u_fit = ph["u"]
    notes = []
    scale_factor = None
    if separate and records.ref_ia is not None:
        if records.scale_factor is None:
            raise AccelcalError("separating the IA motion needs the scale factor of the sensor")
        scale_factor = records.scale_factor
        notes.append("shaker motion along IA removed with the scale factor")
    ratio = w_ratio(ph, scale_factor)
    signed = None
    if estimator == "fundamental":
        sT = np.abs(ratio)
        # first-order propagation of the two amplitudes' standard uncertainties
        std = np.hypot(u_fit.amplitude_std, sT * ph["ref"].amplitude_std) / a_ref
        signed = ratio.real
    else:
        _, m = whole_period_samples(records.u.shape[-1], records.sample_rate,
                                    records.frequency, what="shaker record")
        used = records.u[..., :m]
        if estimator == "peak":
            sT = np.abs(used).max(axis=-1) / a_ref  # Eqs. (21)-(22) [GuanTang]
        else:
            sT = (used.max(axis=-1) - used.min(axis=-1)) / (2 * a_ref)
        std = u_fit.residual_std * (np.sqrt(2 * np.log(2 * m)) + PEAK_COVERAGE) / a_ref
        notes.append(f"{estimator}: whole-period span of {m} samples")
    return TransverseSweep(
        estimator=estimator, amplitude=float(records.amplitude), theta=records.theta, sT=sT,
        sT_std=std, s_I=float(s_I), axial=axial, unit=records.output_unit,
        gravity=float(records.gravity), signed=signed, dc=u_fit.dc,
        p2w=u_fit.phasors[..., 1] / p_ref**2, notes=tuple(notes),
    )


def sweep(sensor, amplitudes, theta, estimator: str, *, gravity: float = 0.0,
          axial: str = "eq20", rng: np.random.Generator | None = None,
          **rig) -> list[TransverseSweep]:
    """Simulate the shaker test at each amplitude and estimate s_T(theta).

    Parameters
    ----------
    sensor : ErrorModel or LinearModel
    amplitudes : iterable of float
        Vibration amplitudes, g (each > 0).
    theta : array_like
        Direction angles, rad.
    estimator : str
        See :data:`ESTIMATORS`.
    gravity : float
        Static gravity along the vibration axis, g.
    axial : str
        Axial sensitivity definition for the relative values.
    rng : numpy.random.Generator, optional
        Noise source; noise-free without it.
    **rig
        Further :class:`~accelcal.rigs.shaker.ShakerRig` settings.

    Returns
    -------
    list of TransverseSweep
        One per amplitude.
    """
    check_estimator(estimator)
    s_I = axial_sensitivity(sensor, axial)
    out = []
    for amp in amplitudes:
        if not amp > 0:
            raise AccelcalError(f"vibration amplitude {amp} g must be positive")
        records = ShakerRig(amplitude=float(amp), gravity=gravity, **rig).simulate(
            sensor, theta, rng=rng)
        out.append(estimate_sT(records, estimator, s_I=s_I, axial=axial))
    return out
