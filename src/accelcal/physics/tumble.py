"""Tumble geometry: specific force at the positions, the design, input checks.

The accelerometer is turned about one of its own axes through N positions
theta_j in the gravity field (1 g). About the output axis (OA) the specific
force is ``a_i = cos(theta)``, ``a_p = sin(theta)``, ``a_o = 0``; about the
pendulum axis (PA, the indexing head of Dong2014) it is ``a_i = sin(theta)``,
``a_o = cos(theta)``, ``a_p = 0``.

The model (see :mod:`accelcal.model`) is linear in the output-unit
coefficients ``b_t = K1 K_t`` (with ``b_K1 = K1``)::

    E(theta) = sum_t b_t f_t(theta)

so a position set identifies exactly the linear functionals of ``b`` in the
row space of the design ``D[j, t] = f_t(theta_j)`` (:func:`design_matrix`).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021, eqs. (1)-(3).
.. [DOMAIN] accelcal domain notes, sections 4 and 5.
"""

from collections.abc import Sequence

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.terms import TERMS

AXES = ("OA", "PA")
"""Rotation axes: the accelerometer's output axis or pendulum axis."""

FULL_TERMS: dict[str, tuple[str, ...]] = {
    "OA": ("K0", "K1", "K2", "K3", "K4", "Kp", "Kpp", "Kip"),
    "PA": ("K0", "K1", "K2", "K3", "K4", "Ko", "Koo", "Kio"),
}
"""Every symmetric term a rotation about each axis excites (asymmetry aside)."""

DEFAULT_TERMS: dict[str, tuple[str, ...]] = {
    "OA": ("K0", "K1", "K2", "K3", "K4", "Kp", "Kip"),
    "PA": ("K0", "K1", "K2", "K3", "K4", "Ko", "Kio"),
}
"""Terms the reduction estimates by default: the IEEE Fourier set. The
cross-axis nonlinearity (Kpp about OA, Koo about PA) is left out because no
rotation about a single axis separates it from K0 and K2 (a_i^2 + a_p^2 = 1
about OA, a_i^2 + a_o^2 = 1 about PA): without it, K0 and K2 stand for
K0 + Kpp and K2 - Kpp (OA) or K0 + Koo and K2 - Koo (PA)."""

ASYMMETRY_TERMS = ("K0_asym", "K1_asym")
"""Optional asymmetry terms, ``1/2 sgn(a_i) (K0' + K1' a_i)``."""

_SNAP = 4.0 * np.finfo(float).eps
"""|cos|, |sin| below this are exactly zero (cos(pi/2) rounds to 6e-17)."""

_ANGLE_TOL = 1e-9
"""Two angles closer than this (rad, modulo 2 pi) are the same position."""


def specific_force(angles_rad, rotation_axis: str = "OA"):
    """Specific force (a_i, a_o, a_p) in g at tumble angles theta.

    Parameters
    ----------
    angles_rad : array_like
        Head angles theta, rad.
    rotation_axis : {"OA", "PA"}
        About OA: ``a_i = cos theta, a_p = sin theta``; about PA:
        ``a_i = sin theta, a_o = cos theta``. Components within 4 eps of
        zero are set to exactly zero (so that ``sgn(a_i)`` is 0 where the
        input axis is horizontal).

    Returns
    -------
    tuple of numpy.ndarray
        ``(a_i, a_o, a_p)``, each of the shape of ``angles_rad``.

    References
    ----------
    .. [1] DOMAIN section 5 (OA); Dong2014 set-up, DOMAIN section 4 (PA).
    """
    axis = check_axis(rotation_axis)
    theta = np.asarray(angles_rad, dtype=float)
    c, s = _snap(np.cos(theta)), _snap(np.sin(theta))
    zero = np.zeros_like(theta)
    if axis == "OA":
        return c, zero, s  # [DOMAIN] section 5
    return s, c, zero  # [Dong2014] set-up, a_i = sin b, a_o = cos b


def design_matrix(angles_rad, rotation_axis: str = "OA", terms=None) -> np.ndarray:
    """Regressors ``f_t(theta_j)`` of the output-unit coefficients ``b_t = K1 K_t``.

    ``E(theta_j) = sum_t b_t f_t(theta_j)``: ``f_K1 = a_i``, ``f_K0 = 1``,
    ``f_K2 = a_i^2``, ``f_Kp = a_p``, ``f_Kip = a_i a_p``, ...,
    ``f_K0_asym = sgn(a_i)/2``, ``f_K1_asym = sgn(a_i) a_i / 2``.

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
    rotation_axis : {"OA", "PA"}
    terms : sequence of str, optional
        Default :data:`FULL_TERMS` of the axis.

    Returns
    -------
    numpy.ndarray, shape (N, p)

    References
    ----------
    .. [1] Guan2021 eqs. (1)-(3) with K4 [IEEE1293]: the model of accelcal.model.
    """
    axis = check_axis(rotation_axis)
    terms = check_terms(terms, axis, FULL_TERMS[axis])
    a_i, a_o, a_p = specific_force(angles_rad, axis)
    sgn = np.sign(a_i)
    columns = {
        "K0": np.ones_like(a_i),
        "K1": a_i,
        "K2": a_i**2,
        "K3": a_i**3,
        "K4": a_i**4,
        "Ko": a_o,
        "Kp": a_p,
        "Koo": a_o**2,
        "Kpp": a_p**2,
        "Kio": a_i * a_o,
        "Kip": a_i * a_p,
        "K0_asym": 0.5 * sgn,  # Eq. (3) [Guan2021]
        "K1_asym": 0.5 * sgn * a_i,  # Eq. (3) [Guan2021]
    }
    return np.column_stack([columns[t] for t in terms])


# --------------------------------------------------------------- validation
def _snap(x):
    return np.where(np.abs(x) < _SNAP, 0.0, x)


def check_axis(axis) -> str:
    """``axis`` if it is one of :data:`AXES`; else an AccelcalError."""
    if axis not in AXES:
        raise AccelcalError(f"rotation axis {axis!r} is not one of {', '.join(AXES)}",
                            parameter="rotation_axis")
    return axis


def check_terms(terms, axis, default) -> tuple[str, ...]:
    """The terms to use about ``axis`` (``default`` for None), validated."""
    if terms is None:
        return tuple(default)
    if isinstance(terms, str) or not isinstance(terms, Sequence):
        raise AccelcalError(f"terms must be a sequence of term names, got {terms!r}",
                            parameter="terms")
    allowed = (*FULL_TERMS[axis], *ASYMMETRY_TERMS)
    terms = tuple(terms)
    for t in terms:
        if t not in allowed:
            why = (
                "is not a model term"
                if t not in TERMS
                else f"does not apply to a rotation about {axis}"
            )
            raise AccelcalError(f"term {t!r} {why}; valid terms here are: {', '.join(allowed)}",
                                parameter="terms")
    if len(set(terms)) != len(terms):
        raise AccelcalError(f"terms {list(terms)} repeat a name; give each term once",
                            parameter="terms")
    if "K1" not in terms:
        raise AccelcalError("terms must include K1 (the scale factor)", parameter="terms")
    return terms


def check_angles(angles_rad) -> np.ndarray:
    """The positions as a 1-D float array: finite and distinct modulo 2 pi."""
    angles = np.asarray(angles_rad, dtype=float)
    if angles.ndim != 1 or angles.size == 0:
        raise AccelcalError(
            f"angles must be a 1-D array of positions in rad; got shape {angles.shape}",
            parameter="angles_rad",
        )
    if not np.isfinite(angles).all():
        raise AccelcalError("angles contain NaN or infinite values; give finite angles in rad",
                            parameter="angles_rad")
    wrapped = np.mod(angles, 2 * np.pi)
    order = np.argsort(wrapped)
    gaps = np.diff(np.append(wrapped[order], wrapped[order[0]] + 2 * np.pi))
    close = np.flatnonzero(gaps < _ANGLE_TOL)
    if angles.size > 1 and close.size:
        i, j = order[close[0]], order[(close[0] + 1) % angles.size]
        raise AccelcalError(
            f"positions {i} and {j} are the same angle modulo 360 deg "
            f"({np.degrees(wrapped[i]):.9g} deg); give distinct positions "
            "(average repeated readings, or pass them with repeats=True)",
            parameter="angles_rad",
        )
    return angles


def check_outputs(outputs, n) -> np.ndarray:
    """The outputs as a float array of shape ``(..., n)``, all finite."""
    y = np.asarray(outputs, dtype=float)
    if y.ndim == 0 or y.shape[-1] != n:
        raise AccelcalError(f"outputs must have shape (..., {n}) for {n} positions; got {y.shape}")
    bad = ~np.isfinite(y)
    if bad.any():
        first = np.argwhere(bad)[0]
        raise AccelcalError(
            f"outputs contain {int(bad.sum())} NaN or infinite value(s), the first at index "
            f"{tuple(int(i) for i in first)}; remove or repeat those readings"
        )
    return y


def is_uniform(angles) -> bool:
    """Whether ``angles`` are N equally spaced positions (any start, any order)."""
    n = angles.size
    if n < 2:
        return False
    wrapped = np.sort(np.mod(angles, 2 * np.pi))
    gaps = np.diff(np.append(wrapped, wrapped[0] + 2 * np.pi))
    return bool(np.all(np.abs(gaps - 2 * np.pi / n) < _ANGLE_TOL))
