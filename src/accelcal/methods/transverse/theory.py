"""Transverse sensitivity on a shaker: closed forms (GuanTang, after ISO 16063-31).

The accelerometer is vibrated along a direction at angle ``theta`` in its
transverse plane (see :mod:`accelcal.rigs.shaker`). With ``a_i = 0`` the
inertial model (GuanTang eq. (13)) gives the transverse output ::

    u_T = k_i [k_0 + a B(theta) + a^2 C(theta)],   a = G + a_v(t)
    B = k_o sin(theta) + k_p cos(theta)
    C = k_oo sin^2(theta) + k_pp cos^2(theta) + k_op sin(theta) cos(theta)

and the linear vibration-accelerometer model (eq. (2)) the figure of eight
``s_T = sqrt(s_o^2 + s_p^2) |sin(theta + alpha)|``. The transverse
sensitivity depends on how the output's amplitude is defined; each
estimator (:mod:`accelcal.methods.transverse.estimators`) is named in every
result:

``peak``
    max over whole periods of ``|u_T(t)|`` divided by A_v (GuanTang eqs.
    (21)-(22)); includes k_0 and the a^2 term, so it depends on A_v.
``half-p2p``
    ``(max - min) / 2`` over whole periods divided by A_v.
``fundamental``
    amplitude of the w component of ``u_T`` (three-parameter sine fit,
    IEEE 1057) divided by that of the reference: ``k_i |B + 2 G C|``.

This module holds their closed forms, the axial sensitivity definitions,
the validation of direction angles and the parameter set of GuanTang Fig. 4.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (2), (7)-(12), (13)-(25) as reconstructed
   in docs/domain.md section 3.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration sensitivity.
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3.1, three-parameter sine fit.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.model import ErrorModel
from accelcal.rigs.shaker import LinearModel

ESTIMATORS = ("peak", "half-p2p", "fundamental")
"""Amplitude estimators of the transverse output."""

AXIAL_DEFINITIONS = ("eq20", "symmetric")
"""Axial sensitivity definitions: GuanTang eq. (20), or (u(+1 g) - u(-1 g)) / 2."""


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
    check_estimator(estimator)
    if not amplitude > 0:
        raise AccelcalError(f"{amplitude} g must be positive", parameter="amplitude")
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
    check_axial(definition)
    up = float(sensor.output(1.0))
    if definition == "eq20":
        return up  # Eq. (20) [GuanTang]
    return 0.5 * (up - float(sensor.output(-1.0)))  # [DOMAIN] symmetric axial sensitivity


# ------------------------------------------------------------------ angles
def check_angles(angles_deg, *, minimum: int = 1) -> np.ndarray:
    """Validate direction angles in degrees; return them in radians.

    Angles must be finite, lie within one full turn, ``0 <= theta < 360``,
    and be distinct.

    A direction has one spelling here, on purpose: -30 deg and 330 deg are the
    same direction, but the angle names the record file
    (``shaker_A5g_theta330.00.csv``), is stored as ``angle_deg`` and orders
    the sweep, so two spellings would give two names and two orders for one
    direction, and a negative value is more often a slip (the convention is
    from PA towards OA, 0 to 360 deg) than a choice. Values outside are
    refused with the equivalent value in [0, 360) in the message rather than
    normalised silently.

    Raises
    ------
    AccelcalError
        With the offending angle (and its equivalent in [0, 360)), or when
        fewer than ``minimum`` angles are given.

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
    bad = a[(a < 0) | (a >= 360)]
    if bad.size:
        raise AccelcalError(
            f"direction angle {bad[0]:g} deg is outside one full turn [0, 360) deg; it is "
            f"the direction {np.mod(bad[0], 360.0):g} deg: give that (e.g. 0:355:5)"
        )
    if np.unique(np.round(a, 9)).size != a.size:
        raise AccelcalError("direction angles repeat (modulo 360 deg); give each once")
    return np.deg2rad(a)


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


def check_estimator(estimator: str) -> None:
    """Refuse an ``estimator`` not in :data:`ESTIMATORS` (AccelcalError)."""
    if estimator not in ESTIMATORS:
        raise AccelcalError(f"{estimator!r} is not one of {', '.join(ESTIMATORS)}",
                            parameter="estimator")


def check_axial(axial: str) -> None:
    """Refuse an ``axial`` definition not in :data:`AXIAL_DEFINITIONS` (AccelcalError)."""
    if axial not in AXIAL_DEFINITIONS:
        raise AccelcalError(
            f"axial definition {axial!r} is not one of {', '.join(AXIAL_DEFINITIONS)}",
            parameter="axial",
        )
