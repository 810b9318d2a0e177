"""Units at the boundaries: g, angles, output units.

Inside accelcal, specific force is in g, angles are in radians and outputs
are in the model's output unit (see :data:`OUTPUT_UNITS`). Degrees and
arcseconds appear only at the boundaries (files, command line, reports);
these helpers convert there.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, IEEE Specification Format Guide and Test
   Procedure for Linear Single-Axis, Nongyroscopic Accelerometers.
"""

from typing import Literal, get_args

import numpy as np

OutputUnit = Literal["V", "mV", "mA", "g"]
"""Units an accelerometer's output may be expressed in."""

OUTPUT_UNITS: tuple[str, ...] = get_args(OutputUnit)

ARCSEC = np.pi / (180.0 * 3600.0)
"""One arcsecond in radians."""

DEG = np.pi / 180.0
"""One degree in radians."""

PPM = 1e-6
"""One part per million."""

STANDARD_GRAVITY = 9.80665
"""Standard acceleration of gravity g_n in m/s^2 (CGPM 1901), used only to
convert to and from SI; the local gravity of a test site is always an input."""


def arcsec_to_rad(value):
    """Convert arcseconds to radians (array-like in, ndarray or float out)."""
    return np.asarray(value, dtype=float) * ARCSEC


def rad_to_arcsec(value):
    """Convert radians to arcseconds."""
    return np.asarray(value, dtype=float) / ARCSEC


def deg_to_rad(value):
    """Convert degrees to radians."""
    return np.asarray(value, dtype=float) * DEG


def rad_to_deg(value):
    """Convert radians to degrees."""
    return np.asarray(value, dtype=float) / DEG
