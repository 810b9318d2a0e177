"""Local gravity: WGS84 normal gravity (Somigliana) with a free-air height correction.

A triad calibrated on static positions is scaled by the local gravity g:
at 1e-4 g the choice matters (g varies by 0.5 % from the equator to the
poles). Give a measured value when there is one; otherwise the normal
gravity of the WGS84 ellipsoid at the site's geodetic latitude,

    g(phi) = g_e (1 + k sin^2 phi) / sqrt(1 - e^2 sin^2 phi)      # Eq. (4-1) [TR8350.2]

with g_e = 9.7803253359 m/s^2, k = 0.00193185265241, e^2 =
0.00669437999013, less 3.086e-6 m/s^2 per metre of height above the
ellipsoid (the free-air gradient, DOMAIN section 6).

References
----------
.. [TR8350.2] NIMA TR8350.2, Department of Defense World Geodetic System
   1984, 3rd ed., 2000, eq. (4-1) and table 3.4 (normal gravity constants).
"""

import math

from accelcal.errors import AccelcalError

GAMMA_E = 9.7803253359
"""Normal gravity at the equator, m/s^2 [TR8350.2, table 3.4]."""

GAMMA_P = 9.8321849378
"""Normal gravity at the poles, m/s^2 [TR8350.2, table 3.4]."""

SOMIGLIANA_K = 0.00193185265241
"""Somigliana's constant k = (b gamma_p)/(a gamma_e) - 1 [TR8350.2, table 3.4]."""

E2 = 0.00669437999013
"""First eccentricity squared of the WGS84 ellipsoid [TR8350.2, table 3.3]."""

FREE_AIR = 3.086e-6
"""Free-air gradient, (m/s^2) per metre of height."""

HEIGHT_RANGE = (-1000.0, 20000.0)
"""Heights accepted, m: from below the Dead Sea shore (-430 m) to above any laboratory
or aircraft test; the linear free-air correction stays within 1e-5 relative there."""

GRAVITY_RANGE = (9.7, 9.9)
"""Accepted local gravity, m/s^2: Earth's surface gravity lies within it
(9.78 at the equator to 9.83 at the poles, less with altitude), and a value
given in g (about 1) or in ft/s^2 (about 32) falls outside."""


def normal_gravity(latitude_deg, height_m=0.0) -> float:
    """WGS84 normal gravity at a geodetic latitude and height, m/s^2.

    Parameters
    ----------
    latitude_deg : float
        Geodetic latitude, degrees, within +-90.
    height_m : float
        Height above the ellipsoid, m, within :data:`HEIGHT_RANGE`.

    Returns
    -------
    float

    Raises
    ------
    AccelcalError
        Naming ``latitude_deg`` or ``height_m`` when out of range or not a number.

    References
    ----------
    .. [1] NIMA TR8350.2 (2000), eq. (4-1); DOMAIN section 6 (free-air term).

    Examples
    --------
    >>> round(normal_gravity(45.0), 6)
    9.806198
    """
    lat = _number(latitude_deg, "latitude_deg")
    h = _number(height_m, "height_m")
    if not -90.0 <= lat <= 90.0:
        raise AccelcalError(f"{lat:g} deg must be a latitude within -90..90 deg",
                            parameter="latitude_deg")
    if not HEIGHT_RANGE[0] <= h <= HEIGHT_RANGE[1]:
        raise AccelcalError(f"{h:g} m must be a height within {HEIGHT_RANGE[0]:g}.."
                            f"{HEIGHT_RANGE[1]:g} m", parameter="height_m")
    s2 = math.sin(math.radians(lat)) ** 2
    g0 = GAMMA_E * (1.0 + SOMIGLIANA_K * s2) / math.sqrt(1.0 - E2 * s2)  # Eq. (4-1) [TR8350.2]
    return g0 - FREE_AIR * h


def check_gravity(gravity, name: str = "gravity") -> float:
    """A local gravity value in m/s^2 (within the 9.7..9.9 of Earth's surface)."""
    g = _number(gravity, name)
    if not GRAVITY_RANGE[0] <= g <= GRAVITY_RANGE[1]:
        raise AccelcalError(f"{g:g} must be the local gravity in m/s^2, within "
                            f"{GRAVITY_RANGE[0]:g}..{GRAVITY_RANGE[1]:g} (a value in g is about "
                            "1; give m/s^2)", parameter=name)
    return g


def _number(value, name: str) -> float:
    if isinstance(value, bool):
        value = None
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise AccelcalError(f"{value!r} must be a number", parameter=name) from None
    if not math.isfinite(x):
        raise AccelcalError(f"{x!r} must be finite", parameter=name)
    return x
