"""Closed forms of the vibration rectification error (VRE) under overload and vibration.

A vibrafuge (centrifuge plus shaker) applies an overload ``b`` and a
sinusoidal vibration ``A sin(theta)`` together. The VRE is the whole-period
mean of the output while vibrating minus the mean at rest, in g (output
divided by the scale factor). Along the input axis, with the error model of
:class:`accelcal.ErrorModel` [Guan2021]_ ::

    dU1 = 1/2 (K2 + 3 K3 b) A^2  (+ K4 (3 A^2 b^2 + 3/8 A^4))            Eq. (9)
    dU2 = 1/2 K0' (E[sgn a_i] - sgn b) + 1/2 K1' (E|a_i| - |b|)         Eqs. (21)/(24)
    dU  = dU1 + dU2,   r = dU2 / dU                                     Eqs. (23), (25)

For ``A > |b|``, with ``phi = arccos(|b| / A)`` in ``(0, pi/2]``::

    E[sgn a_i] - sgn b = -(2/pi) sgn(b) phi
    E|a_i| - |b|       = (2A/pi) (sin phi - phi cos phi)

and both vanish for ``A <= |b|``. This form holds for either sign of ``b``
(the paper assumes ``b > 0``, where it equals its eq. (21)) and is evaluated
without cancellation near ``A = |b|``.

In the general case the overload and the vibration are vectors projected on
IA/OA/PA, ``a_j = A_j sin(theta) + b_j`` with ``A_j = A u_j`` for a unit
direction ``u``. Every polynomial term of the model averages in closed form
(mean of sin^2 is 1/2, of sin^3 is 0, of sin^4 is 3/8); only the asymmetry
term needs the formulas above, with ``A_i = |A u_i|`` and ``b = b_i``.
:func:`vre_columns` gives the VRE per unit of every coefficient, which is
both the closed form (:func:`vector_vre`) and the design matrix of the
identification (:func:`accelcal.methods.vre.identify`).

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (4)-(25) and Table 1.
.. [DOMAIN] accelcal domain notes, section 2 (corrected form for either sign
   of b and for the multi-axis case).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.model import ErrorModel

VRE_TERMS = ("K2", "K3", "K4", "Koo", "Kpp", "Kio", "Kip", "Kop", "K0_asym", "K1_asym")
"""Coefficients that produce a rectification error. The bias, the scale
factor and the linear cross-axis terms (K0, K1, Ko, Kp) average out over a
period and can never be identified from VRE."""

PAPER_TERMS = ("K2", "K3", "K0_asym", "K1_asym")
"""The coefficients Guan2021 uses (its Table 1)."""

_SERIES_SWITCH = 0.5
"""Below this phi (rad), sin(phi) - phi cos(phi) is summed as a series."""

# sin(x) - x cos(x) = sum_k (-1)^(k+1) 2k x^(2k+1) / (2k+1)!, k = 1..10, as
# coefficients of x^3 * (x^2)^(k-1); the k = 11 term is below 1e-26 x^3 for x < 0.5.
_SERIES = np.array(
    [(-1.0) ** (k + 1) * 2 * k / float(np.prod(np.arange(1, 2 * k + 2))) for k in range(1, 11)]
)


def _finite(value, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float)
    if not np.isfinite(arr).all():
        raise AccelcalError("has non-finite values (NaN or inf); give finite numbers",
                            parameter=what)
    return arr


def _amplitude(value, what: str = "amplitude") -> np.ndarray:
    arr = _finite(value, what)
    if (arr < 0).any():
        raise AccelcalError(
            f"{arr[arr < 0].ravel()[0]:g} g is negative; a vibration amplitude is >= 0 "
            "(give the direction's sign through the direction vector)", parameter=what,
        )
    return arr


def _sin_minus_x_cos(x: np.ndarray) -> np.ndarray:
    """``sin(x) - x cos(x)`` for ``0 <= x <= pi/2`` without cancellation at small x."""
    x2 = x * x
    series = np.zeros_like(x)
    for c in _SERIES[::-1]:
        series = series * x2 + c
    series = series * x2 * x
    return np.where(x < _SERIES_SWITCH, series, np.sin(x) - x * np.cos(x))


def sgn_shape(overload, amplitude):
    """The two asymmetry shape functions of the VRE, per unit K0' and K1'.

    Parameters
    ----------
    overload : array_like
        Overload ``b`` along IA, g (any sign).
    amplitude : array_like
        Vibration amplitude ``A`` along IA, g (>= 0). Broadcasts with
        ``overload``.

    Returns
    -------
    s0 : numpy.ndarray
        ``1/2 (E[sgn a_i] - sgn b)``: the VRE per g of K0'.
    s1 : numpy.ndarray
        ``1/2 (E|a_i| - |b|)``: the VRE per unit K1', in g.

    Notes
    -----
    ``a_i = A sin(theta) + b`` over a whole period. For ``A <= |b|`` the
    sign never changes (at ``A = |b|`` it touches zero at one point, a set
    of measure zero) and both are 0; at ``b = A = 0`` the input is
    identically zero and both are 0 too (sgn(0) = 0).

    References
    ----------
    .. [1] Guan2021, eqs. (14)-(21) and (24); [DOMAIN] section 2 for b <= 0.
    """
    b = _finite(overload, "overload")
    A = _amplitude(amplitude)
    b, A = np.broadcast_arrays(b, A)
    crossing = np.abs(b) < A
    # phi = arccos(|b|/A) as the angle of a right triangle with legs scaled by A:
    # accurate near A = |b| (A - |b| is exact there) and free of under/overflow.
    A_safe = np.where(crossing, A, 1.0)
    b_abs = np.where(crossing, np.abs(b), 0.0)
    rho = b_abs / A_safe
    leg = np.sqrt(((A_safe - b_abs) / A_safe) * ((A_safe + b_abs) / A_safe))
    phi = np.arctan2(leg, rho)
    s0 = np.where(crossing, -np.sign(b) * phi / np.pi, 0.0)  # Eq. (21) [Guan2021], K0' part
    s1 = np.where(crossing, A * _sin_minus_x_cos(phi) / np.pi, 0.0)  # Eq. (21), K1' part
    return s0, s1


def even_order_vre(overload, amplitude, K2, K3, K4=0.0):
    """dU1: the VRE of the input-axis polynomial terms, g.

    Parameters
    ----------
    overload, amplitude : array_like
        ``b`` (any sign) and ``A`` (>= 0) along IA, g; they broadcast.
    K2, K3, K4 : float or array_like
        Second-, third- and fourth-order coefficients, g/g^n.

    Returns
    -------
    numpy.ndarray
        ``1/2 (K2 + 3 K3 b) A^2 + K4 (3 A^2 b^2 + 3/8 A^4)``.

    References
    ----------
    .. [1] Guan2021, eq. (9) (the K4 term is omitted in the paper as small;
       it follows from the mean of sin^4 = 3/8).
    """
    b = _finite(overload, "overload")
    A = _amplitude(amplitude)
    A2 = A * A
    du1 = 0.5 * (K2 + 3.0 * K3 * b) * A2  # Eq. (9) [Guan2021]
    return du1 + K4 * (3.0 * A2 * b * b + 0.375 * A2 * A2)


def asymmetry_vre(overload, amplitude, K0_asym, K1_asym):
    """dU2: the VRE of the asymmetry term, g, for either sign of b.

    Parameters
    ----------
    overload, amplitude : array_like
        ``b`` (any sign) and ``A`` (>= 0) along IA, g; they broadcast.
    K0_asym, K1_asym : float or array_like
        Bias asymmetry K0' (g) and scale-factor asymmetry K1' (-).

    Returns
    -------
    numpy.ndarray
        ``(1/pi) [K1' A (sin phi - phi cos phi) - sgn(b) K0' phi]`` with
        ``phi = arccos(|b|/A)`` when ``A > |b|``, else 0. At ``b = 0`` it is
        ``K1' A / pi``.

    References
    ----------
    .. [1] Guan2021, eqs. (21), (22), (24); [DOMAIN] section 2.
    """
    s0, s1 = sgn_shape(overload, amplitude)
    return K0_asym * s0 + K1_asym * s1  # Eq. (24) [Guan2021]


def relative_error(du1, du2):
    """Relative error r = dU2 / (dU1 + dU2), a fraction; NaN where dU = 0.

    References
    ----------
    .. [1] Guan2021, eq. (25).
    """
    du1 = np.asarray(du1, dtype=float)
    du2 = np.asarray(du2, dtype=float)
    total = du1 + du2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(total != 0.0, du2 / np.where(total != 0.0, total, 1.0), np.nan)  # (25)


@dataclass(frozen=True)
class VreTable:
    """dU1, dU2, dU and r over a grid of overloads and amplitudes.

    Every array has shape ``(len(overloads), len(amplitudes))``; rows are
    overloads.

    Attributes
    ----------
    overload, amplitude : numpy.ndarray
        The grid, g.
    du1, du2, du : numpy.ndarray
        Even-order, asymmetry and total VRE, g.
    r : numpy.ndarray
        Relative error dU2/dU (fraction; NaN where dU = 0).
    """

    overload: np.ndarray
    amplitude: np.ndarray
    du1: np.ndarray
    du2: np.ndarray
    du: np.ndarray
    r: np.ndarray

    def rows(self) -> list[dict]:
        """One dict per (b, A) pair, overload-major, with the CLI's column names."""
        return [
            {"overload_g": float(b), "amplitude_g": float(a), "dU1_g": float(d1),
             "dU2_g": float(d2), "dU_g": float(d), "r": float(r)}
            for b, a, d1, d2, d, r in zip(
                *(x.ravel() for x in (self.overload, self.amplitude, self.du1, self.du2,
                                      self.du, self.r)), strict=True)
        ]


def vre_table(model: ErrorModel, overloads, amplitudes) -> VreTable:
    """The paper's table: dU1, dU2, dU and r for every (b, A) of a grid.

    Parameters
    ----------
    model : ErrorModel
        Supplies K2, K3, K4, K0' and K1' (other terms do not act along IA).
    overloads, amplitudes : array_like, 1-D
        Overloads ``b`` (any sign) and amplitudes ``A`` (>= 0) along IA, g.

    Returns
    -------
    VreTable

    Raises
    ------
    AccelcalError
        For an empty grid, negative amplitudes, non-finite values, or a VRE
        beyond the float range.

    References
    ----------
    .. [1] Guan2021, eqs. (9), (21)-(25), Table 1.

    Examples
    --------
    >>> from accelcal import ErrorModel
    >>> m = ErrorModel(K2=7.87e-6, K3=1.19e-7, K0_asym=2.26e-6, K1_asym=1.45e-6)
    >>> t = vre_table(m, [1.0], [5.0])
    >>> round(float(t.du1[0, 0]) * 1e6, 4), round(float(t.r[0, 0]), 5)
    (102.8375, 0.00622)
    """
    b = _finite(overloads, "overload").reshape(-1)
    A = _amplitude(amplitudes).reshape(-1)
    if b.size == 0 or A.size == 0:
        raise AccelcalError("the overload and amplitude grids must each have at least one value")
    bb, AA = np.meshgrid(b, A, indexing="ij")
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite values refused below
        du1 = even_order_vre(bb, AA, model.K2, model.K3, model.K4)
        du2 = asymmetry_vre(bb, AA, model.K0_asym, model.K1_asym)
        du = du1 + du2  # Eq. (23) [Guan2021]
    if not (np.isfinite(du1).all() and np.isfinite(du2).all() and np.isfinite(du).all()):
        raise AccelcalError(
            "the VRE is beyond the float range: the overloads, amplitudes or coefficients are "
            "not those of an accelerometer; give smaller values")
    return VreTable(bb, AA, du1, du2, du, relative_error(du1, du2))


def _unit_direction(direction) -> np.ndarray:
    u = _finite(direction, "direction")
    if u.shape[-1:] != (3,):
        raise AccelcalError(
            f"direction must have 3 components (IA, OA, PA), got shape {u.shape}"
        )
    norm = np.linalg.norm(u, axis=-1, keepdims=True)
    if (norm == 0).any():
        raise AccelcalError("direction is the zero vector; give a direction in IA, OA, PA")
    return u / norm


def along_ia(overload) -> np.ndarray:
    """Overload vectors (..., 3) in IA/OA/PA for overloads ``b`` along IA."""
    b = _finite(overload, "overload")
    return np.stack([b, np.zeros_like(b), np.zeros_like(b)], axis=-1)


def _overload_vector(overload) -> np.ndarray:
    b = _finite(overload, "overload")
    if b.ndim == 0 or b.shape[-1] != 3:
        raise AccelcalError(
            f"overload must be vectors with 3 components (IA, OA, PA), got shape {b.shape}; "
            "use along_ia(b) for overloads along the input axis"
        )
    return b


def vre_columns(overload, amplitude, direction=(1.0, 0.0, 0.0)) -> dict[str, np.ndarray]:
    """VRE per unit of every rectifying coefficient, in g per coefficient unit.

    Parameters
    ----------
    overload : array_like, shape (..., 3)
        Overload vector in IA, OA, PA (g); :func:`along_ia` builds it from
        overloads along IA.
    amplitude : array_like, shape (...)
        Vibration amplitude along ``direction``, g (>= 0).
    direction : array_like, shape (..., 3)
        Vibration direction in IA, OA, PA (normalised here).

    Returns
    -------
    dict of str to numpy.ndarray
        For each name of :data:`VRE_TERMS`, the VRE that a unit value of
        that coefficient produces, broadcast over the inputs. The VRE of a
        model is ``sum(model.<term> * column)`` (:func:`vector_vre`).

    Notes
    -----
    With ``a_j = A_j sin(theta) + b_j``: the mean of ``a_j a_k - b_j b_k`` is
    ``A_j A_k / 2``; of ``a_i^3 - b_i^3`` is ``3/2 b_i A_i^2``; of
    ``a_i^4 - b_i^4`` is ``3 A_i^2 b_i^2 + 3/8 A_i^4``; linear terms give 0.

    References
    ----------
    .. [1] Guan2021, eqs. (4), (8), (9), (21); [DOMAIN] section 2 (vector case).
    """
    b = _overload_vector(overload)
    u = _unit_direction(direction)
    A = _amplitude(amplitude)
    amp = A[..., None] * u  # Eq. (4) [Guan2021]: A_j, signed components
    amp, b = np.broadcast_arrays(amp, b)
    Ai, Ao, Ap = amp[..., 0], amp[..., 1], amp[..., 2]
    bi = b[..., 0]
    s0, s1 = sgn_shape(bi, np.abs(Ai))
    return {
        "K2": 0.5 * Ai * Ai,  # Eq. (9) [Guan2021]
        "K3": 1.5 * bi * Ai * Ai,  # Eq. (9) [Guan2021]
        "K4": 3.0 * Ai * Ai * bi * bi + 0.375 * Ai**4,
        "Koo": 0.5 * Ao * Ao,
        "Kpp": 0.5 * Ap * Ap,
        "Kio": 0.5 * Ai * Ao,
        "Kip": 0.5 * Ai * Ap,
        "Kop": 0.5 * Ao * Ap,
        "K0_asym": s0,  # Eq. (21) [Guan2021]
        "K1_asym": s1,  # Eq. (21) [Guan2021]
    }


def vector_vre(model: ErrorModel, overload, amplitude, direction=(1.0, 0.0, 0.0)):
    """Closed-form VRE (g) of every model term for vector overload and vibration.

    Parameters
    ----------
    model : ErrorModel
    overload, amplitude, direction
        As in :func:`vre_columns`.

    Returns
    -------
    total : numpy.ndarray
        The VRE in g.
    by_term : dict of str to numpy.ndarray
        Each term's contribution (terms of :data:`VRE_TERMS`).

    References
    ----------
    .. [1] Guan2021, eqs. (2)-(4), (9), (21), (23); [DOMAIN] section 2.
    """
    cols = vre_columns(overload, amplitude, direction)
    by_term = {name: getattr(model, name) * col for name, col in cols.items()}
    return sum(by_term.values()), by_term  # Eq. (23) [Guan2021]
