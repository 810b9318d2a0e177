"""Centrifuge geometry: the sensor's orientation on the arm and the specific force it feels.

Arm frame (DOMAIN section 9): ``r`` radial, pointing inward to the spin axis,
``t`` along the motion, ``z`` up (the spin axis). At a rate Omega the proof
mass at radius R feels the specific force (in g after division by
g_n = 9.80665 m/s^2) ::

    f = Omega^2 R r + g z (+ R dOmega/dt t while the rate changes)        # Eq. (9.1) [DOMAIN]

and, for a proof mass at arm coordinates X (outward) and Y (along t), in
general ::

    f = (Omega^2 X + dOmega/dt Y) r + (dOmega/dt X - Omega^2 Y) t + g u   # Eq. (9.2)

with ``u`` the local vertical in the rig frame (``z`` without spin-axis
tilt). The sensor's axes IA, OA, PA are the rows ``i, o, p`` of an
orientation matrix ``C`` (arm coordinates, det +1), so that
``(a_i, a_o, a_p) = C f`` (Eq. (9.3)); :data:`POSITIONS` holds the named
positions and :func:`orientation` builds any other from three angles.

The rig errors the reductions model (:data:`RIG_ERRORS`) enter through
``X = R0 (1 + radius_error + arm_stretch Omega^2) - d (i . r)``,
``Y = d (i . t)`` (proof-mass offset ``d`` along IA) and a small rotation of
the sensor on the arm (misalignment, three angles about its own IA, OA, PA).
A rate error ``e`` scales Omega^2 by ``(1 + e)^2``: it is indistinguishable
from the radius error, which therefore stands for ``dR/R + 2 dOmega/Omega``.

References
----------
.. [IEEE836] IEEE Std 836-2009, IEEE Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, section 9 (specific force on the arm,
   rig errors, identifiability).
.. [Goldstein] Goldstein H., Poole C., Safko J., Classical Mechanics, 3rd
   ed., Addison-Wesley, 2002, sec. 4.10 (acceleration in a rotating frame).
"""

from collections.abc import Sequence

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.terms import TERMS
from accelcal.units import STANDARD_GRAVITY
from accelcal.validation import shown

_ROWS = {
    "IA-in": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "IA-out": ((-1, 0, 0), (0, -1, 0), (0, 0, 1)),
    "OA-in": ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
    "OA-out": ((0, 0, 1), (-1, 0, 0), (0, -1, 0)),
    "PA-in": ((0, 0, 1), (0, -1, 0), (1, 0, 0)),
    "PA-out": ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
    "IA-tan": ((0, 1, 0), (1, 0, 0), (0, 0, -1)),
}
POSITIONS: dict[str, np.ndarray] = {k: np.array(v, dtype=float) for k, v in _ROWS.items()}
"""Named positions: rows IA, OA, PA in arm coordinates (r inward, t along the motion, z up).

``IA-in``/``IA-out``: IA radial inward/outward, PA up (a_i = +-A, a_p = 1);
``OA-in``/``OA-out``: OA radial, IA up (a_i = 1, a_o = +-A);
``PA-in``/``PA-out``: PA radial, IA up (a_i = 1, a_p = +-A);
``IA-tan``: IA tangential, OA radial inward, PA down (a_i = 0, a_o = A, a_p = -1)."""

FULL_TERMS = ("K0", "K1", "K2", "K3", "K4", "Ko", "Kp", "Koo", "Kpp", "Kio", "Kip", "Kop")
"""Symmetric model terms a centrifuge can excite (asymmetry: :data:`ASYMMETRY_TERMS`)."""

ASYMMETRY_TERMS = ("K0_asym", "K1_asym")

RIG_ERRORS = ("radius_error", "arm_stretch", "proof_mass_offset")
"""Rig errors common to every step: relative radius error (dR/R + 2 dOmega/Omega),
arm stretch s in R = R0 (1 + s Omega^2) (s^2), proof-mass offset along IA (m).
Misalignments are per position: ``misalignment:<position>:<axis>`` (rad)."""

RIG_UNITS = {"radius_error": "-", "arm_stretch": "s^2", "proof_mass_offset": "m"}
MISALIGNMENT_AXES = ("IA", "OA", "PA")

_SNAP = 4.0 * np.finfo(float).eps
"""Orientation entries below this are exactly zero (cos 90 deg rounds to 6e-17)."""

MAX_ANGLE_DEG = 720.0
"""Largest orientation angle accepted, deg (two turns)."""


def misalignment_name(position: str, axis: str) -> str:
    """Name of the misalignment angle of ``position`` about the sensor's ``axis`` (IA, OA, PA)."""
    return f"misalignment:{position}:{axis}"


def rig_unit(name: str) -> str:
    """Unit of a rig-error parameter."""
    return RIG_UNITS.get(name, "rad")


def orientation(angles_deg) -> np.ndarray:
    """Orientation matrix (rows IA, OA, PA in arm coordinates) from three angles.

    ``C = (Rz(yaw) Ry(pitch) Rx(roll))^T``: at zero angles the sensor is in
    position ``IA-in`` (IA along r, OA along t, PA up); the angles turn its
    axes about the arm's z (yaw), then y = t (pitch), then x = r (roll),
    right-handed in the (r, t, z) coordinates.

    Parameters
    ----------
    angles_deg : sequence of 3 float
        Yaw, pitch, roll, degrees.

    Returns
    -------
    numpy.ndarray, shape (3, 3)

    Examples
    --------
    >>> np.array_equal(orientation((180, 0, 0)), POSITIONS["IA-out"])
    True
    """
    a = np.asarray(angles_deg, dtype=float).reshape(-1)
    if a.size != 3 or not np.isfinite(a).all() or (np.abs(a) > MAX_ANGLE_DEG).any():
        raise AccelcalError(f"orientation angles {shown(list(a))} must be three finite angles "
                            f"(yaw, pitch, roll) within +-{MAX_ANGLE_DEG:g} deg",
                            parameter="positions")
    y, p, r = np.radians(a)
    cz, sz, cy, sy, cx, sx = (_snap(v) for v in (np.cos(y), np.sin(y), np.cos(p), np.sin(p),
                                                 np.cos(r), np.sin(r)))
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    return _snap((rz @ ry @ rx).T)


def position_matrix(spec) -> np.ndarray:
    """Orientation matrix of a position: a name of :data:`POSITIONS` or ``{"angles_deg": ...}``."""
    if isinstance(spec, str):
        if spec not in POSITIONS:
            raise AccelcalError(f"position {shown(spec)} is not one of {', '.join(POSITIONS)} "
                                "(or give three angles)", parameter="positions")
        return POSITIONS[spec].copy()
    if isinstance(spec, dict):
        if spec.get("name") in POSITIONS and "angles_deg" not in spec:
            return POSITIONS[spec["name"]].copy()
        if "angles_deg" in spec:
            return orientation(spec["angles_deg"])
    raise AccelcalError(f"position {shown(spec)} is neither a named position nor three angles",
                        parameter="positions")


def small_rotation(angles) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues' formula), shape ``(..., 3, 3)``.

    References
    ----------
    .. [1] Goldstein et al., sec. 4.7 (finite rotations).
    """
    v = np.asarray(angles, dtype=float)
    theta = np.linalg.norm(v, axis=-1)[..., None, None]
    k = np.zeros((*v.shape[:-1], 3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    k = k - np.swapaxes(k, -1, -2)
    # sin(x)/x and (1 - cos x)/x^2 without division by zero
    s = np.sinc(theta / np.pi)
    c = 0.5 * np.sinc(theta / (2 * np.pi)) ** 2
    return np.eye(3) + s * k + c * (k @ k)


def misaligned(c, angles) -> np.ndarray:
    """Orientation of a sensor turned from ``c`` by small angles about its own IA, OA, PA.

    ``C' = Q(d)^T C`` with ``Q`` the rotation of vector ``d`` in sensor
    coordinates: the new axes are ``C^T Q`` columns, i.e. rows of ``Q^T C``.
    """
    return np.swapaxes(small_rotation(angles), -1, -2) @ c


def specific_force(c, rate, radius, *, gravity=STANDARD_GRAVITY, radius_error=0.0,
                   arm_stretch=0.0, proof_mass_offset=0.0, rate_dot=0.0, up=(0.0, 0.0, 1.0)):
    """Specific force (a_i, a_o, a_p) in g of a sensor on the arm.

    Parameters
    ----------
    c : array_like, shape (..., 3, 3)
        Orientation (rows IA, OA, PA in arm coordinates), already misaligned.
    rate : array_like
        Spin rate Omega, rad/s (broadcasts with the leading axes of ``c``).
    radius : float
        Nominal radius R0 of the reference point, m.
    gravity : float
        Local gravity, m/s^2.
    radius_error, arm_stretch, proof_mass_offset : float
        Rig errors (see the module notes): relative, s^2, m.
    rate_dot : array_like
        dOmega/dt, rad/s^2 (0 at a steady rate).
    up : array_like, shape (..., 3)
        Local vertical in arm coordinates (z without tilt).

    Returns
    -------
    tuple of numpy.ndarray
        ``(a_i, a_o, a_p)`` in g.

    References
    ----------
    .. [1] DOMAIN section 9; Goldstein et al. sec. 4.10.
    """
    c = np.asarray(c, dtype=float)
    w2 = np.asarray(rate, dtype=float) ** 2
    wd = np.asarray(rate_dot, dtype=float)
    i_r, i_t = c[..., 0, 0], c[..., 0, 1]
    x = radius * (1.0 + radius_error + arm_stretch * w2) - proof_mass_offset * i_r
    y = proof_mass_offset * i_t
    up = np.asarray(up, dtype=float)
    f = np.stack([w2 * x + wd * y + gravity * up[..., 0],  # Eq. (9.2) [DOMAIN]
                  wd * x - w2 * y + gravity * up[..., 1],
                  np.broadcast_to(gravity * up[..., 2], np.shape(w2 * x))], axis=-1)
    a = np.einsum("...jk,...k->...j", c, f) / STANDARD_GRAVITY  # Eq. (9.3)
    return a[..., 0], a[..., 1], a[..., 2]


def regressors(a_i, a_o, a_p, terms, *, sign=None) -> np.ndarray:
    """Columns ``f_t(a)`` of the output-unit coefficients ``b_t = K1 K_t``, shape ``(n, p)``.

    ``sign`` replaces ``sgn(a_i)`` in the asymmetry terms when given.

    References
    ----------
    .. [1] Guan2021 eqs. (1)-(3) with K4 [IEEE1293]: the model of accelcal.model.
    """
    sgn = np.sign(a_i) if sign is None else sign
    cols = {"K0": np.ones_like(a_i), "K1": a_i, "K2": a_i**2, "K3": a_i**3, "K4": a_i**4,
            "Ko": a_o, "Kp": a_p, "Koo": a_o**2, "Kpp": a_p**2, "Kio": a_i * a_o,
            "Kip": a_i * a_p, "Kop": a_o * a_p,
            "K0_asym": 0.5 * sgn, "K1_asym": 0.5 * sgn * a_i}  # Eq. (3) [Guan2021]
    return np.column_stack([cols[t] for t in terms])


def gradients(a_i, a_o, a_p, terms, b, *, sign=None) -> np.ndarray:
    """Derivatives of ``sum_t b_t f_t(a)`` with respect to (a_i, a_o, a_p), shape ``(n, 3)``.

    ``d sgn(a)/da`` is taken as 0 (the model's asymmetry term is piecewise linear).
    """
    b = dict(zip(terms, b, strict=True))
    g = {t: b.get(t, 0.0) for t in (*FULL_TERMS, *ASYMMETRY_TERMS)}
    di = (g["K1"] + a_i * (2 * g["K2"] + a_i * (3 * g["K3"] + 4 * g["K4"] * a_i))
          + g["Kio"] * a_o + g["Kip"] * a_p
          + 0.5 * g["K1_asym"] * (np.sign(a_i) if sign is None else sign))
    do = g["Ko"] + 2 * g["Koo"] * a_o + g["Kio"] * a_i + g["Kop"] * a_p
    dp = g["Kp"] + 2 * g["Kpp"] * a_p + g["Kip"] * a_i + g["Kop"] * a_o
    return np.stack(np.broadcast_arrays(di, do, dp), axis=-1)


def check_terms(terms, default) -> tuple[str, ...]:
    """The terms to estimate (``default`` for None), validated; K1 required."""
    if terms is None:
        return tuple(default)
    if isinstance(terms, str) or not isinstance(terms, Sequence):
        raise AccelcalError(f"must be a sequence of term names, got {shown(terms)}",
                            parameter="terms")
    allowed = (*FULL_TERMS, *ASYMMETRY_TERMS)
    terms = tuple(terms)
    for t in terms:
        if t not in allowed:
            why = "is not a model term" if t not in TERMS else "is not estimated (noise)"
            raise AccelcalError(f"{shown(t)} {why}; valid terms: {', '.join(allowed)}",
                                parameter="terms")
    if len(set(terms)) != len(terms):
        raise AccelcalError(f"{list(terms)} repeat a name; give each term once",
                            parameter="terms")
    if "K1" not in terms:
        raise AccelcalError("must include K1 (the scale factor)", parameter="terms")
    return tuple(t for t in allowed if t in terms)


def _snap(x):
    return np.where(np.abs(x) < _SNAP, 0.0, x)
