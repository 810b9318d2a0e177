"""When is a plateau usable: settling of the sensor temperature during the soak.

A plateau's tumble is usable when the sensor has reached the chamber's
temperature: over the last ``window`` seconds of the soak (before the
tumble), the least-squares rate of change of the sensor temperature is
below ``rate_limit`` (degC/min) in magnitude. The settling time reported is
the time from the start of the soak after which the sensor temperature
stays within ``tolerance`` of its final value (the mean over the window);
for a first-order lag after a step ``dT`` it is ``tau ln(dT / tolerance)``
[Ogata 5-3]. A plateau that does not settle is refused: its coefficients
would carry the lag and the thermal-transient bias.

The defaults (window 600 s, 0.01 degC/min, 0.1 degC) are those of a
navigation-grade test; IEEE Std 1293-2018 leaves the stabilisation criterion
to the test procedure, which states it (docs/thermal.md).

References
----------
.. [Ogata] Ogata K., Modern Control Engineering, 5th ed., sec. 5-3.
.. [IEEE1293] IEEE Std 1293-2018, thermal tests (temperature stabilisation
   before each measurement).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError

WINDOW_S = 600.0
"""Default window at the end of the soak, s."""
RATE_LIMIT = 0.01
"""Default largest rate of change of the sensor temperature over the window, degC/min."""
TOLERANCE = 0.1
"""Default band about the final temperature for the settling time, degC."""


@dataclass(frozen=True)
class Settling:
    """The settling of one plateau.

    Attributes
    ----------
    settled : bool
        Rate over the window below the limit.
    rate : float
        Least-squares rate of the sensor temperature over the window, degC/min.
    final : float
        Mean sensor temperature over the window, degC.
    settling_time : float
        s from the start of the soak until the temperature stays within the
        tolerance of ``final`` (NaN when it never does).
    samples : int
        Readings in the window.
    """

    settled: bool
    rate: float
    final: float
    settling_time: float
    samples: int


def check_settings(window: float, rate_limit: float, tolerance: float) -> None:
    """Refuse a window, rate limit or tolerance that is not positive and finite."""
    for name, value in (("window", window), ("rate_limit", rate_limit),
                        ("tolerance", tolerance)):
        if not (np.isfinite(value) and value > 0):
            raise AccelcalError(f"{name} = {value} must be a positive number", parameter=name)


def settling(t, temperature, *, window: float = WINDOW_S, rate_limit: float = RATE_LIMIT,
             tolerance: float = TOLERANCE) -> Settling:
    """Whether a soak settled (module docs).

    Parameters
    ----------
    t : array_like, shape (n,)
        Times of the soak readings, s (increasing).
    temperature : array_like, shape (n,)
        Sensor temperature, degC.
    window, rate_limit, tolerance : float
        s, degC/min, degC.

    Returns
    -------
    Settling
        ``settled`` is False when the window holds fewer than 3 readings.
    """
    check_settings(window, rate_limit, tolerance)
    t, temp = np.asarray(t, dtype=float), np.asarray(temperature, dtype=float)
    if t.size == 0:
        return Settling(False, np.nan, np.nan, np.nan, 0)
    last = t >= t[-1] - window
    n = int(last.sum())
    tw, yw = t[last], temp[last]
    final = float(yw.mean())
    rate = np.nan
    if n >= 3:
        dtw = tw - tw.mean()
        rate = float(np.sum(dtw * (yw - final)) / np.sum(dtw**2)) * 60.0  # LS slope, degC/min
    outside = np.flatnonzero(np.abs(temp - final) > tolerance)
    if outside.size == 0:
        when = 0.0
    elif outside[-1] + 1 < t.size:
        when = float(t[outside[-1] + 1] - t[0])
    else:
        when = np.nan
    return Settling(bool(n >= 3 and abs(rate) <= rate_limit), rate, final, when, n)
