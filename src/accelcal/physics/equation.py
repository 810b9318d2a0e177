"""The error model's equation: the indicated acceleration of given specific force.

With specific force components a_i, a_o, a_p in g along the input (IA),
output (OA) and pendulum (PA) axes and the coefficients of
:class:`~accelcal.model.ErrorModel` (in g per g^n), the indicated
acceleration in g is ::

    E/K1 = K0 + a_i + K2 a_i^2 + K3 a_i^3 + K4 a_i^4 + Ko a_o + Kp a_p
           + Koo a_o^2 + Kpp a_p^2 + Kio a_i a_o + Kip a_i a_p + Kop a_o a_p
           + 1/2 sgn(a_i) (K0' + K1' a_i)

with sgn(0) = 0 (:func:`indicated_g`). The model adds its noise and scale
factor; the rigs and the methods evaluate the same equation through it.

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (1)-(3).
.. [IEEE1293] IEEE Std 1293-2018, model equation with K4.
"""

import numpy as np

from accelcal.errors import AccelcalError

MAX_SPECIFIC_FORCE_G = 1e6
"""Largest specific force (g) the model is evaluated at: beyond shock-test
levels (about 1e5 g), and small enough that a polynomial term cannot
overflow for any sensible coefficient."""


def indicated_g(c, a_i, a_o=0.0, a_p=0.0):
    """Indicated acceleration E/K1 in g, noise-free.

    Parameters
    ----------
    c : mapping
        The coefficients by name (``K0``, ``K2``, ..., ``K0_asym``, ``K1_asym``),
        in g per g^n; arrays broadcast with the inputs.
    a_i, a_o, a_p : array_like
        Specific force along IA, OA and PA in g (numpy broadcasting).

    Returns
    -------
    numpy.ndarray or float
        E/K1 in g, of the broadcast shape of the inputs.

    Raises
    ------
    AccelcalError
        If an input is not finite or beyond :data:`MAX_SPECIFIC_FORCE_G`
        in magnitude, or the output overflows.

    References
    ----------
    .. [1] Guan2021, eqs. (2)-(3); IEEE1293 for K4.
    """
    a_i, a_o, a_p = (check_specific_force(v, n)
                     for v, n in ((a_i, "a_i"), (a_o, "a_o"), (a_p, "a_p")))
    with np.errstate(over="ignore", invalid="ignore"):
        # Eq. (2) [Guan2021], with K4 [IEEE1293]; a_i polynomial in Horner form.
        u = c["K0"] + a_i * (1.0 + a_i * (c["K2"] + a_i * (c["K3"] + a_i * c["K4"])))
        u = u + a_o * (c["Ko"] + c["Koo"] * a_o + c["Kio"] * a_i + c["Kop"] * a_p)
        u = u + a_p * (c["Kp"] + c["Kpp"] * a_p + c["Kip"] * a_i)
        if c["K0_asym"] or c["K1_asym"]:
            # Eq. (3) [Guan2021]; np.sign(0) == 0 exactly, as the paper defines sgn.
            u = u + 0.5 * np.sign(a_i) * (c["K0_asym"] + c["K1_asym"] * a_i)
    return check_output(u)


def check_specific_force(value, name: str) -> np.ndarray:
    """A float array of specific force in g: finite, within :data:`MAX_SPECIFIC_FORCE_G`."""
    arr = np.asarray(value, dtype=float)
    if not np.isfinite(arr).all():
        raise AccelcalError(
            f"input {name} has non-finite values (NaN or inf); give finite g values"
        )
    if arr.size and np.abs(arr).max() > MAX_SPECIFIC_FORCE_G:
        raise AccelcalError(
            f"specific force {name} of {np.abs(arr).max():.3g} g is beyond the "
            f"{MAX_SPECIFIC_FORCE_G:.0e} g the model is evaluated at (its polynomial terms "
            "would overflow or mean nothing there); give specific forces in g")
    return arr


def check_output(u):
    """``u`` if every value is finite; else the model overflows for these inputs."""
    if not np.isfinite(u).all():
        raise AccelcalError(
            "the model's output overflows (is not finite) for these inputs: its "
            "coefficients are too large for specific forces this size; check their units"
        )
    return u
