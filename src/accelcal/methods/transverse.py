"""Transverse sensitivity of an accelerometer on a shaker (GuanTang, after ISO 16063-31).

The accelerometer is vibrated along a direction at angle ``theta`` in its
transverse plane (see :mod:`accelcal.rigs.shaker`). With ``a_i = 0`` the
inertial model (GuanTang eq. (13)) gives the transverse output ::

    u_T = k_i [k_0 + a B(theta) + a^2 C(theta)],   a = G + a_v(t)
    B = k_o sin(theta) + k_p cos(theta)
    C = k_oo sin^2(theta) + k_pp cos^2(theta) + k_op sin(theta) cos(theta)

and the linear vibration-accelerometer model (eq. (2)) the figure of eight
``s_T = sqrt(s_o^2 + s_p^2) |sin(theta + alpha)|``. The transverse
sensitivity depends on how the output's amplitude is defined; each
estimator is named in every result:

``peak``
    max over whole periods of ``|u_T(t)|`` divided by A_v (GuanTang eqs.
    (21)-(22)); includes k_0 and the a^2 term, so it depends on A_v.
``half-p2p``
    ``(max - min) / 2`` over whole periods divided by A_v.
``fundamental``
    amplitude of the w component of ``u_T`` (three-parameter sine fit,
    IEEE 1057) divided by that of the reference: ``k_i |B + 2 G C|``.

Beyond the paper, :func:`identify` fits k_o, k_p, k_oo, k_pp, k_op (and
optionally other terms) to the DC, w and 2w components of the records,
with the shaker's measured transverse motion in the regressors.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (2), (7)-(12), (13)-(25) as reconstructed
   in docs/domain.md section 3.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration sensitivity.
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3.1, three-parameter sine fit.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.model import ErrorModel
from accelcal.results import Estimate, least_squares
from accelcal.rigs.shaker import LinearModel, ShakerRecords, ShakerRig
from accelcal.signal.periods import whole_period_samples
from accelcal.signal.sinefit import HarmonicFit

ESTIMATORS = ("peak", "half-p2p", "fundamental")
"""Amplitude estimators of the transverse output."""

AXIAL_DEFINITIONS = ("eq20", "symmetric")
"""Axial sensitivity definitions: GuanTang eq. (20), or (u(+1 g) - u(-1 g)) / 2."""

FIT_TERMS = ("K0", "Ki", "K2", "K3", "K4", "Ko", "Kp", "Koo", "Kpp", "Kop", "Kio", "Kip")
"""Terms whose DC, w and 2w regressors :func:`identify` knows (``Ki`` is the
coefficient of a_i, 1 by definition of K1)."""

ROUTES = ("2w", "dc", "both", "w")
"""Components used by :func:`identify` besides the w phasor."""

PEAK_COVERAGE = 1.0
"""Extra standard deviations added to the expected extreme of the noise in
the peak and half-p2p uncertainty bound (see :func:`estimate_sT`)."""


GUANTANG_FIG4 = ErrorModel.from_guantang(
    k_i=1000.0, k_0=5.0e-5, k_ii=5.0e-6, k_iii=0.0, k_o=2.0e-4, k_p=-1.0e-4,
    k_oo=3.0e-5, k_pp=-2.0e-5, k_op=1.0e-5, output_unit="mV",
)
"""A plausible parameter set for GuanTang Fig. 4 (its Table 1 was lost).

k_i = 1000 mV/g, k_0 = 5e-5 g and k_ii = 5e-6 g/g^2 (k_iii = 0) give
s_I = k_i (k_0 + 1 + k_ii + k_iii) = 1000.055 mV/g, the paper's eq. (25).
The cross-axis terms (k_o = 2e-4, k_p = -1e-4 g/g; k_oo = 3e-5,
k_pp = -2e-5, k_op = 1e-5 g/g^2) are of navigation-grade size and chosen
so that, as the paper reports, the peak-definition polar plot shows four
local maxima and a non-zero minimum at the larger amplitudes.
"""


def figure4_linear() -> LinearModel:
    """Linear model with the same first-order sensitivities as :data:`GUANTANG_FIG4`.

    ``s_i = k_i``, ``s_o = k_i k_o``, ``s_p = k_i k_p`` (GuanTang eq. (2)); its
    s_T is the ISO 16063-31 figure of eight (GuanTang Fig. 3).
    """
    m = GUANTANG_FIG4
    return LinearModel(s_i=m.K1, s_o=m.K1 * m.Ko, s_p=m.K1 * m.Kp, output_unit=m.output_unit)


# ------------------------------------------------------------------ closed forms
def cross_axis_B(theta, model: ErrorModel):
    """``B(theta) = k_o sin(theta) + k_p cos(theta)``, g/g; Eq. (16) [GuanTang] [DOMAIN]."""
    theta = np.asarray(theta, dtype=float)
    return model.Ko * np.sin(theta) + model.Kp * np.cos(theta)


def cross_axis_C(theta, model: ErrorModel):
    """``C(theta) = k_oo sin^2 + k_pp cos^2 + k_op sin cos``, g/g^2; Eq. (24) [GuanTang]."""
    theta = np.asarray(theta, dtype=float)
    s, c = np.sin(theta), np.cos(theta)
    return model.Koo * s * s + model.Kpp * c * c + model.Kop * s * c  # Eq. (24) [GuanTang]


def linear_sT(theta, model: LinearModel):
    """Figure of eight ``sqrt(s_o^2 + s_p^2) |sin(theta + alpha)|``, output unit per g.

    ``alpha = atan2(s_p, s_o)`` (the paper's ``arctan(s_p / s_o)`` loses the
    quadrant when ``s_o < 0``).

    References
    ----------
    .. [1] GuanTang, eqs. (7)-(12).
    """
    alpha = np.arctan2(model.s_p, model.s_o)  # Eq. (9) [GuanTang], quadrant-correct
    return np.hypot(model.s_o, model.s_p) * np.abs(np.sin(np.asarray(theta, float) + alpha))


def closed_form_sT(sensor, theta, amplitude: float, estimator: str, *, gravity: float = 0.0):
    """Transverse sensitivity in closed form, output unit per g.

    Parameters
    ----------
    sensor : ErrorModel or LinearModel
    theta : array_like
        Direction angles, rad.
    amplitude : float
        Vibration amplitude A_v, g (> 0).
    estimator : {"peak", "half-p2p", "fundamental"}
    gravity : float
        Static specific force along the vibration axis, g.

    Returns
    -------
    numpy.ndarray
        s_T(theta). ``peak`` and ``half-p2p`` are the continuous-time
        extremes of ``u_T`` over ``a_v`` in ``[-A_v, A_v]``; a sampled
        record reaches them when its samples include the extremes.

    References
    ----------
    .. [1] GuanTang, eqs. (12), (17)-(18), (21)-(22); docs/domain.md section 3.
    """
    _check_estimator(estimator)
    if not amplitude > 0:
        raise AccelcalError(f"amplitude {amplitude} g must be positive")
    theta = np.asarray(theta, dtype=float)
    if isinstance(sensor, LinearModel):
        b = (sensor.s_o * np.sin(theta) + sensor.s_p * np.cos(theta)) / sensor.s_i
        k1, k0, c = sensor.s_i, 0.0, np.zeros_like(theta)
    else:
        b, c = cross_axis_B(theta, sensor), cross_axis_C(theta, sensor)
        k1, k0 = sensor.K1, sensor.K0
    if estimator == "fundamental":
        return np.abs(k1) * np.abs(b + 2.0 * gravity * c)  # [DOMAIN] k_i |B + 2 G C|
    # u(x) = k1 [k0 + (G + x) B + (G + x)^2 C], x = a_v in [-A, A]; Eq. (16) [GuanTang]
    lin = b + 2.0 * gravity * c
    const = k0 + gravity * b + gravity**2 * c

    def u(x):
        return k1 * (const + x * lin + x * x * c)

    cands = [u(-amplitude), u(amplitude)]
    safe_c = np.where(c != 0, c, 1.0)
    vertex = np.where(c != 0, -lin / (2 * safe_c), np.inf)
    inside = np.abs(vertex) <= amplitude
    cands.append(np.where(inside, u(np.where(inside, vertex, 0.0)), cands[0]))
    cands = np.stack(cands)
    if estimator == "peak":
        return np.abs(cands).max(axis=0) / amplitude  # Eqs. (21)-(22) [GuanTang]
    return (cands.max(axis=0) - cands.min(axis=0)) / (2 * amplitude)


def axial_sensitivity(sensor, definition: str = "eq20") -> float:
    """Axial sensitivity s_I, output unit per g.

    ``eq20``: the output at +1 g along IA divided by 1 g, which for the
    paper's model is ``k_i (k_0 + 1 + k_ii + k_iii)`` (GuanTang eq. (20));
    ``symmetric``: ``(u(+1 g) - u(-1 g)) / 2``, free of the bias and the
    even terms (``k_i (1 + k_iii)`` for the paper's model).

    References
    ----------
    .. [1] GuanTang, eqs. (19)-(20), (25); docs/domain.md section 3.
    """
    if definition not in AXIAL_DEFINITIONS:
        raise AccelcalError(
            f"axial definition {definition!r} is not one of {', '.join(AXIAL_DEFINITIONS)}"
        )
    up = float(sensor.output(1.0))
    if definition == "eq20":
        return up  # Eq. (20) [GuanTang]
    return 0.5 * (up - float(sensor.output(-1.0)))  # [DOMAIN] symmetric axial sensitivity


# ------------------------------------------------------------------ angles
def check_angles(angles_deg, *, minimum: int = 1) -> np.ndarray:
    """Validate direction angles in degrees; return them in radians.

    Angles must be finite, lie within one full turn (``-360 <= theta <= 360``
    and ``max - min < 360``) and be distinct modulo 360.

    Raises
    ------
    AccelcalError
        With the offending angle, or when fewer than ``minimum`` angles are given.

    References
    ----------
    .. [1] GuanTang, Fig. 2 (direction angles theta_1 ... theta_n about IA).
    """
    a = np.atleast_1d(np.asarray(angles_deg, dtype=float))
    if a.ndim != 1 or a.size < minimum:
        raise AccelcalError(
            f"{a.size} direction angle(s) given; at least {minimum} are needed"
            + (" for a fit (3 or more distinct angles)" if minimum >= 3 else "")
        )
    if not np.isfinite(a).all():
        raise AccelcalError("direction angles must be finite (degrees)")
    bad = a[(a < -360) | (a > 360)]
    if bad.size or a.max() - a.min() >= 360:
        raise AccelcalError(
            f"direction angles must lie within one full turn (span < 360 deg, e.g. 0:355:5); "
            f"got {a.min():g} to {a.max():g} deg"
        )
    wrapped = np.round(np.mod(a, 360.0), 9)
    if np.unique(wrapped).size != a.size:
        raise AccelcalError("direction angles repeat (modulo 360 deg); give each once")
    return np.deg2rad(a)


# ------------------------------------------------------------------ estimation
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
    _check_estimator(estimator)
    if not (np.isfinite(s_I) and s_I != 0):
        raise AccelcalError(f"axial sensitivity {s_I} must be finite and non-zero")
    ph = record_phasors(records)
    p_ref = ph["ref"].phasors[..., 0]
    a_ref = np.abs(p_ref)
    u_fit = ph["u"]
    notes = []
    p_u = u_fit.phasors[..., 0]
    if separate and records.ref_ia is not None:
        if records.scale_factor is None:
            raise AccelcalError("separating the IA motion needs the scale factor of the sensor")
        p_u = p_u - records.scale_factor * ph["ref_ia"].phasors[..., 0]
        notes.append("shaker motion along IA removed with the scale factor")
    ratio = p_u / p_ref
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
    _check_estimator(estimator)
    s_I = axial_sensitivity(sensor, axial)
    out = []
    for amp in amplitudes:
        if not amp > 0:
            raise AccelcalError(f"vibration amplitude {amp} g must be positive")
        records = ShakerRig(amplitude=float(amp), gravity=gravity, **rig).simulate(
            sensor, theta, rng=rng)
        out.append(estimate_sT(records, estimator, s_I=s_I, axial=axial))
    return out


# ------------------------------------------------------------------ identification
def regressors(theta, p_v, p_n, p_ia, gravity: float) -> dict:
    """DC (vibrating and at rest), w and 2w regressors of each model term.

    For in-plane specific force ``(G + a_v) e_v + a_n e_n`` and IA motion
    ``a_ia`` with phasors ``P_v, P_n, P_ia`` (convention of
    :mod:`accelcal.signal.sinefit`), each term's contribution to the output
    divided by K1 is its coefficient times the regressor returned here.
    Products of ``x = x0 + Re(X e^{iwt})`` and ``y = y0 + Re(Y e^{iwt})``:
    DC ``x0 y0 + Re(X conj(Y)) / 2``, w ``x0 Y + y0 X``, 2w ``X Y / 2``.

    Returns
    -------
    dict
        Term name (:data:`FIT_TERMS`) -> tuple ``(dc, dc_rest, w, w2)`` of
        arrays of shape ``(..., m)`` (w and w2 complex).

    References
    ----------
    .. [1] GuanTang eq. (13) with a_i = 0 plus the IA motion; docs/domain.md section 3.
    """
    s, c = np.sin(theta), np.cos(theta)
    po = s * p_v + c * p_n  # OA component of the vibration phasor
    pp = c * p_v - s * p_n  # PA component
    o0, p0 = gravity * s, gravity * c
    pi = p_ia
    z = np.zeros_like(po)
    one = np.ones(po.shape)
    return {
        "K0": (one, one, z, z),
        "Ki": (0 * one, 0 * one, pi, z),
        "K2": (np.abs(pi) ** 2 / 2, 0 * one, z, pi**2 / 2),
        "K3": (0 * one, 0 * one, 3 * np.abs(pi) ** 2 * pi / 4, z),
        "K4": (3 * np.abs(pi) ** 4 / 8, 0 * one, z, np.abs(pi) ** 2 * pi**2 / 2),
        "Ko": (o0 * one, o0 * one, po, z),
        "Kp": (p0 * one, p0 * one, pp, z),
        "Koo": (o0**2 + np.abs(po) ** 2 / 2, o0**2 * one, 2 * o0 * po, po**2 / 2),
        "Kpp": (p0**2 + np.abs(pp) ** 2 / 2, p0**2 * one, 2 * p0 * pp, pp**2 / 2),
        "Kop": (o0 * p0 + (po * np.conj(pp)).real / 2, o0 * p0 * one, o0 * pp + p0 * po,
                po * pp / 2),
        "Kio": ((pi * np.conj(po)).real / 2, 0 * one, o0 * pi, pi * po / 2),
        "Kip": ((pi * np.conj(pp)).real / 2, 0 * one, p0 * pi, pi * pp / 2),
    }


DEFAULT_FIT = ("Ko", "Kp", "Koo", "Kpp", "Kop")


_TERM_UNITS = {"K0": "g", "K2": "g/g^2", "K3": "g/g^3", "K4": "g/g^4", "Ko": "g/g", "Kp": "g/g",
               "Koo": "g/g^2", "Kpp": "g/g^2", "Kop": "g/g^2", "Kio": "g/g^2", "Kip": "g/g^2"}


def observation_columns(reg: dict, term: str, route: str) -> np.ndarray:
    """Real observation columns of ``term`` per angle: [DC shift], a1, b1, [a2, b2].

    Parameters
    ----------
    reg : dict
        :func:`regressors` output: per term ``(dc, dc_rest, w, w2)``.
    term : str
        A name of :data:`FIT_TERMS`.
    route : str
        Components used (:data:`ROUTES`): the DC shift with ``dc``/``both``,
        the 2w phasor with ``2w``/``both``; phasors ``P = a - i b``.
    """
    dc, dc_rest, w, w2 = reg[term]
    cols = [w.real, -w.imag]
    if route in ("2w", "both"):
        cols += [w2.real, -w2.imag]
    if route in ("dc", "both"):
        cols = [dc - dc_rest, *cols]
    return np.stack(np.broadcast_arrays(*cols), axis=-1)


def observation_covariance(records: ShakerRecords, ph: dict, route: str, k1: float, *,
                           reference: bool = True) -> np.ndarray:
    """Covariance of each angle's real observations ``[DC shift], a1, b1, [a2, b2]``.

    The output's sine-fit covariance (noise from its residuals), plus the
    output at rest's for the DC shift, plus (``reference=True``) the noise of
    the input-axis reference channel: the IA motion enters the w phasor with
    the known coefficient 1 (times K1, by the definition of K1), so its
    phasor's covariance adds ``K1^2 cov(P_ia)`` to the w components. The
    reference channels' noise entering through the fitted (small) cross-axis
    coefficients is of relative order ``|k_o|`` and neglected.

    Parameters
    ----------
    records : ShakerRecords
        The records, ``(..., m, n)``.
    ph : dict
        Their :func:`record_phasors`.
    route : str
        Components used (:data:`ROUTES`).
    k1 : float
        K1, output unit per g.
    reference : bool
        Include the IA reference channel's noise (when that channel is present).

    Returns
    -------
    numpy.ndarray
        Shape ``(..., m, q, q)``; a floor at rounding level keeps noise-free
        records usable (equal weights).

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1 (sine-fit covariance); GuanTang eq. (13)
       with the IA motion; docs/domain.md section 3.
    """
    u = ph["u"]
    use_dc = route in ("dc", "both")
    sel = ([0] if use_dc else []) + [1, 2] + ([3, 4] if route in ("2w", "both") else [])
    cu = u.cov_unit[np.ix_(sel, sel)]
    scale = np.abs(records.u).max(axis=(-1, -2), initial=1e-300)
    floor = 1e-15 * scale
    s_u = np.maximum(u.residual_std, floor[..., None])
    cov = s_u[..., None, None] ** 2 * cu
    if use_dc:
        s_r = np.maximum(ph["u_rest"].residual_std, floor[..., None])
        first = np.zeros(len(sel))
        first[0] = 1.0
        cov = cov + (s_r**2 * ph["u_rest"].cov_unit[0, 0])[..., None, None] * np.outer(first, first)
    if reference and "ref_ia" in ph:
        w = np.isin(sel, (1, 2)).astype(float)
        s_ia = k1 * ph["ref_ia"].residual_std
        cov = cov + s_ia[..., None, None] ** 2 * (cu * np.outer(w, w))
    return cov


def _system(records: ShakerRecords, route: str, terms, base: ErrorModel | None,
            scale_factor: float | None):
    """Whitened design (..., N, p) and observations (..., N) of the identification."""
    if route not in ROUTES:
        raise AccelcalError(f"route {route!r} is not one of {', '.join(ROUTES)}")
    bad = [t for t in terms if t not in FIT_TERMS or t == "Ki"]
    if bad or not terms or len(set(terms)) != len(terms):
        raise AccelcalError(
            f"terms to fit {list(terms)} must be distinct names among "
            f"{', '.join(t for t in FIT_TERMS if t != 'Ki')}"
        )
    m = records.theta.shape[-1]
    if m < 3:
        raise AccelcalError(
            f"{m} direction angle(s): the fit needs at least 3 distinct angles (e.g. 0:330:30)"
        )
    k1 = scale_factor if scale_factor is not None else (
        base.K1 if base is not None else records.scale_factor)
    if k1 is None or not np.isfinite(k1) or k1 == 0:
        raise AccelcalError("the fit needs the sensor's scale factor K1 (output unit per g)")
    if base is None:
        base = ErrorModel(K1=k1, output_unit=records.output_unit)
    ph = record_phasors(records)
    p_v = ph["ref"].phasors[..., 0]
    p_n = ph["ref_n"].phasors[..., 0] if "ref_n" in ph else np.zeros_like(p_v)
    p_ia = ph["ref_ia"].phasors[..., 0] if "ref_ia" in ph else np.zeros_like(p_v)
    reg = regressors(records.theta, p_v, p_n, p_ia, records.gravity)
    use_dc = route in ("dc", "both")
    if use_dc and records.u_rest is None:
        raise AccelcalError(
            "route 'dc' needs the output at rest at each angle (column u_rest) to form the DC "
            "shift; record it or use route 2w"
        )
    u = ph["u"]
    # real observations per angle, built from (dc, a1, b1, a2, b2) with P = a - i b
    idx = [1, 2] + ([3, 4] if route in ("2w", "both") else [])
    obs = [u.parameters[..., i] for i in idx]
    if use_dc:
        obs = [u.dc - ph["u_rest"].dc, *obs]

    y = np.stack(obs, axis=-1)  # (..., m, q)
    values = base.terms()
    known = observation_columns(reg, "Ki", route)  # coefficient of a_i is 1 by the definition of K1
    for term in FIT_TERMS:
        if term not in terms and term != "Ki" and values.get(term, 0.0) != 0.0:
            known = known + values[term] * observation_columns(reg, term, route)
    y = y - k1 * known
    # (..., m, q, p)
    design = k1 * np.stack([observation_columns(reg, t, route) for t in terms], axis=-1)
    cov = observation_covariance(records, ph, route, k1)
    chol = np.linalg.cholesky(cov)
    yw = np.linalg.solve(chol, y[..., None])[..., 0]
    dw = np.linalg.solve(chol[..., None, :, :], design.swapaxes(-1, -2)[..., None]).squeeze(-1)
    dw = dw.swapaxes(-1, -2)  # (..., m, q, p)
    lead = y.shape[:-2]
    scale = np.abs(records.u).max(axis=(-1, -2), initial=1e-300)
    return (dw.reshape(*lead, -1, len(terms)), yw.reshape(*lead, -1), k1,
            bool(np.all(u.residual_std > 1e-12 * scale[..., None])))


def identify(records: ShakerRecords, *, route: str = "2w", terms=DEFAULT_FIT,
             base: ErrorModel | None = None, scale_factor: float | None = None) -> Estimate:
    """Identify cross-axis coefficients from shaker records at several angles.

    Fits the chosen terms (default k_o, k_p, k_oo, k_pp, k_op) to the w
    phasor of the output (k_o, k_p through ``B(theta)``, and the ``2 G C``
    part under gravity) and to the 2w phasor and/or the DC shift from rest
    (k_oo, k_pp, k_op through ``C(theta)``). The regressors use the
    reference channels, so a measured transverse motion of the shaker
    (``ref_n``, ``ref_ia``) is separated exactly. Observations are weighted
    by the covariance of each angle's observations
    (:func:`observation_covariance`: the output's sine fit and the IA
    reference channel's noise, both estimated from the fit residuals), so
    the returned covariance is ``(A' W A)^-1``.

    Parameters
    ----------
    records : ShakerRecords
        Records of shape ``(m, n)``, m >= 3 angles.
    route : {"2w", "dc", "both", "w"}
        Components used besides the w phasor; ``dc`` needs ``u_rest``.
    terms : sequence of str
        Terms to fit (names of :data:`FIT_TERMS` except ``Ki``).
    base : ErrorModel, optional
        Values of the terms not fitted (default: all zero) and K1.
    scale_factor : float, optional
        K1, output unit per g (default: ``base.K1`` or the records' value).

    Returns
    -------
    Estimate
        Method ``transverse-<route>``; the values are in g/g^n.

    Raises
    ------
    AccelcalError
        For fewer than 3 angles, an unknown term or route, a rank-deficient
        design (e.g. k_oo, k_pp, k_op from the w phasor alone without gravity),
        or a zero reference amplitude.

    Notes
    -----
    Neglected: the noise of the reference channels along the vibration and
    across it, which enters through the small fitted coefficients (relative
    order ``|k_o|``), the asymmetry terms' response to IA motion and the 3w
    component.

    References
    ----------
    .. [1] GuanTang eqs. (13), (16), (24), beyond the paper; docs/domain.md section 3.
    """
    if records.u.ndim != 2:
        raise AccelcalError("identify takes records of shape (angles, samples); "
                            "use identify_arrays for stacked trials")
    design, y, k1, noisy = _system(records, route, tuple(terms), base, scale_factor)
    notes = ["observations weighted by each record's sine-fit covariance",
             ("the IA reference channel's noise included in the weights; the other "
              "reference channels' noise, entering through the small fitted "
              "coefficients, neglected")]
    if not noisy:
        notes.append("noise-free records: covariance is not meaningful")
    return least_squares(design, y, names=tuple(terms),
                        units={t: _TERM_UNITS[t] for t in terms},
                        method=f"transverse-{route}", sigma=1.0, notes=notes,
                        provenance={"angles": int(records.theta.size),
                                    "amplitude_g": records.amplitude,
                                    "gravity_g": records.gravity, "scale_factor": k1})


def identify_arrays(records: ShakerRecords, *, route: str = "2w", terms=DEFAULT_FIT,
                    base: ErrorModel | None = None, scale_factor: float | None = None):
    """Vectorised :func:`identify` over leading (trial) axes of the records.

    Returns
    -------
    values : numpy.ndarray, shape (..., p)
    covariance : numpy.ndarray, shape (..., p, p)

    References
    ----------
    .. [1] docs/domain.md section 3 (identification beyond GuanTang).
    """
    design, y, _, _ = _system(records, route, tuple(terms), base, scale_factor)
    ata = design.swapaxes(-1, -2) @ design
    cov = np.linalg.inv(ata)
    values = (cov @ (design.swapaxes(-1, -2) @ y[..., None]))[..., 0]
    return values, cov


def fundamental_extremes(model: ErrorModel) -> dict:
    """Closed-form extremes of the ``fundamental`` s_T without gravity.

    ``k_i |B(theta)|`` has maximum ``|k_i| sqrt(k_o^2 + k_p^2)`` at
    ``theta_max = atan2(k_o, k_p)`` (mod 180 deg) and zero minimum 90 deg away.

    References
    ----------
    .. [1] docs/domain.md section 3 (figure of eight of the w component).
    """
    th = np.mod(np.arctan2(model.Ko, model.Kp), np.pi)
    return {"S_Tmax": abs(model.K1) * float(np.hypot(model.Ko, model.Kp)),
            "theta_max_deg": float(np.rad2deg(th)), "S_Tmin": 0.0,
            "theta_min_deg": float(np.rad2deg(np.mod(th + np.pi / 2, np.pi)))}


def _check_estimator(estimator: str) -> None:
    if estimator not in ESTIMATORS:
        raise AccelcalError(f"estimator {estimator!r} is not one of {', '.join(ESTIMATORS)}")
