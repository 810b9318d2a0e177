"""The frequency response of a force-rebalance accelerometer: a closed loop's transfer function.

To a first approximation the servo accelerometer's complex sensitivity is a
second-order low pass, optionally with an extra real pole and a pure delay
from its electronics (DOMAIN.md section 10)::

    S(s) = S0 wn^2 / (s^2 + 2 zeta wn s + wn^2) * 1 / (1 + s / wp) * exp(-s tau),

``s = i 2 pi f``, ``wn = 2 pi fn``, ``wp = 2 pi fp``. Phasors follow
:mod:`accelcal.signal.sinefit`: a signal ``Re(P exp(i w t))`` through ``S``
becomes ``Re(S(i w) P exp(i w t))``, so an output lagging its input has a
negative phase. The rig (:mod:`accelcal.rigs.shaker_response`) simulates by
it and the method (:mod:`accelcal.methods.response`) fits it; the
polynomials are evaluated by :func:`scipy.signal.freqs`.

References
----------
.. [ISO16063-21] ISO 16063-21:2003, sec. 3 (complex sensitivity).
.. [Ogata2010] Ogata K., Modern Control Engineering, 5th ed., 2010, sec. 5-3
   (second-order systems: resonance, bandwidth).
"""

import numpy as np


def polynomials(s0: float, fn: float, zeta: float, pole_hz: float | None = None):
    """Numerator and denominator of ``S(s)`` without the delay, highest power first."""
    wn = 2.0 * np.pi * fn
    den = np.array([1.0, 2.0 * zeta * wn, wn * wn])
    if pole_hz is not None:
        den = np.polymul(den, [1.0 / (2.0 * np.pi * pole_hz), 1.0])
    return np.array([s0 * wn * wn]), den


def transfer(f, s0: float, fn: float, zeta: float, *, pole_hz: float | None = None,
             delay_s: float = 0.0) -> np.ndarray:
    """Complex sensitivity ``S(i 2 pi f)`` at frequencies ``f`` (Hz), in the unit of ``s0``.

    Parameters
    ----------
    f : array_like
        Frequencies, Hz (>= 0).
    s0 : float
        Static sensitivity (output unit per g).
    fn : float
        Natural frequency, Hz.
    zeta : float
        Damping ratio.
    pole_hz : float, optional
        Corner of the extra real pole, Hz (none by default).
    delay_s : float
        Pure delay, s.

    Returns
    -------
    numpy.ndarray of complex
        ``S`` at each frequency.
    """
    from scipy.signal import freqs

    w = 2.0 * np.pi * np.atleast_1d(np.asarray(f, dtype=float))
    b, a = polynomials(s0, fn, zeta, pole_hz)
    _, h = freqs(b, a, worN=w)
    return h * np.exp(-1j * w * delay_s)
