"""Indexing-head model: the basis Psi, coefficient names and units, the first-harmonic alias.

Each sensor's own angle is ``beta_k = alpha + phi_k`` (nominal head angle
plus mount phase) and its model (Dong2014 eq. (5), a_p = 0) is ::

    U = K_F + K_I sin(g) + K_O cos(g) + K_IO sin(g) cos(g) + K_II sin(g)^2,
    g = beta + d_alpha + eta_k

with d_alpha the head's angular position error. Every reduction fits the
basis ``Psi(beta) = [1, sin b, cos b, sin b cos b, sin^2 b]`` per sensor.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (5), (23)-(26).
.. [DOMAIN] accelcal domain notes, section 4 (corrected expansions and
   reduction steps 0-7).
"""

import numpy as np

FAMILY = "dividing-head"
"""The method family (:data:`accelcal.methods.REGISTRY` key)."""

COEFFICIENTS = ("K_F", "K_I", "K_O", "K_IO", "K_II")
"""Dong2014 eq. (5) coefficient names, in the order of the basis Psi."""

METHODS = ("single", "four", "joint", "tumble")
"""Reductions of indexing-head data (:func:`~accelcal.methods.dividing_head.reduce`)."""

FIRST_ORDER_NOTE = (
    "K_O is K_O* = K_O + K_I (eta + d0): misalignment and the mean head error "
    "cannot be separated from K_O by the accelerometers alone "
    "(accelcal docs/domain.md, section 4, step 6)"
)


def method_name(reduction) -> str:
    """The head reduction's short name (``single``, ``four``, ``joint``, ``tumble``)."""
    return reduction.method.removeprefix(f"{FAMILY}/")


def coefficient_units(output_unit: str = "V") -> dict[str, str]:
    """Units of the Dong2014 coefficients for outputs in ``output_unit``."""
    return {
        "K_F": output_unit, "K_I": f"{output_unit}/g", "K_O": f"{output_unit}/g",
        "K_IO": f"{output_unit}/g^2", "K_II": f"{output_unit}/g^2",
    }


def angle_names(n: int) -> tuple[str, ...]:
    """Names of the per-position head angle errors."""
    return tuple(f"d_alpha[{j}]" for j in range(n))


def psi(beta) -> np.ndarray:
    """The basis ``[1, sin b, cos b, sin b cos b, sin^2 b]``, shape ``(..., n, 5)``.

    References
    ----------
    .. [1] Dong2014, eq. (23) (matrix Psi).
    """
    b = np.asarray(beta, dtype=float)
    s, c = np.sin(b), np.cos(b)
    return np.stack([np.ones_like(b), s, c, s * c, s * s], axis=-1)  # Eq. (23) [Dong2014]


def first_harmonic_alias(first_harmonic, mounts) -> np.ndarray:
    """What a first harmonic of the head error adds to each sensor's normalised fit.

    With ``d_alpha = d1c cos(alpha) + d1s sin(alpha)`` and sensor k at
    phase phi_k, regressing U/K_I on Psi(beta_k) returns the coefficients
    plus ``[c', 0, 0, s', -c']`` with ``c' = d1c cos phi - d1s sin phi`` and
    ``s' = d1c sin phi + d1s cos phi`` [DOMAIN step 4]. Multiply by K_I for
    volts.

    Parameters
    ----------
    first_harmonic : array_like, shape (..., 2)
        (d1c, d1s), rad.
    mounts : array_like, shape (K,)
        Mount phases, rad.

    Returns
    -------
    numpy.ndarray, shape (..., K, 5)

    References
    ----------
    .. [1] Dong2014, eqs. (25)-(26), corrected as [DOMAIN] section 4, step 4.
    """
    h = np.asarray(first_harmonic, dtype=float)
    phi = np.asarray(mounts, dtype=float)
    c1, s1 = h[..., 0, None], h[..., 1, None]
    cp = c1 * np.cos(phi) - s1 * np.sin(phi)  # c' [DOMAIN step 4]
    sp = c1 * np.sin(phi) + s1 * np.cos(phi)  # s' [DOMAIN step 4]
    zero = np.zeros_like(cp)
    return np.stack([cp, zero, zero, sp, -cp], axis=-1)  # Eq. (25)-(26) corrected [DOMAIN]


def alias_jacobian(mounts) -> np.ndarray:
    """d(alias)/d(d1c, d1s), shape (K, 5, 2)."""
    return np.stack(
        [first_harmonic_alias([1.0, 0.0], mounts), first_harmonic_alias([0.0, 1.0], mounts)],
        axis=-1,
    )


def harmonics(alpha: np.ndarray, m_max: int) -> np.ndarray:
    """Columns ``[1, cos a, sin a, ..., cos m_max a, sin m_max a]``, shape ``(n, 2 m_max + 1)``."""
    cols = [np.ones_like(alpha)]
    for m in range(1, m_max + 1):
        cols += [np.cos(m * alpha), np.sin(m * alpha)]
    return np.stack(cols, axis=-1)


def is_uniform(alpha: np.ndarray) -> bool:
    """True when the angles are n equally spaced positions over the circle (any start)."""
    wrapped = np.sort(np.mod(alpha - alpha[0], 2 * np.pi))
    steps = np.diff(np.append(wrapped, 2 * np.pi))
    return bool(np.allclose(steps, 2 * np.pi / alpha.size, rtol=0, atol=1e-9))
