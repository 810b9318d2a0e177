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


# ------------------------------------------------------------- unit algebra
UNIT_SIZES: dict[str, dict[str, float]] = {
    "acceleration": {"g": 1.0, "mg": 1e-3, "ug": 1e-6, "m/s^2": 1.0 / STANDARD_GRAVITY},
    "ratio": {"1": 1.0, "g/g": 1.0, "%": 1e-2, "mg/g": 1e-3, "ppm": PPM, "rad": 1.0,
              "mrad": 1e-3, "urad": 1e-6, "deg": DEG, "arcsec": ARCSEC},
    "voltage/g": {"V/g": 1.0, "mV/g": 1e-3},
    "current/g": {"mA/g": 1.0, "uA/g": 1e-3},
    "second-order": {"g/g^2": 1.0, "mg/g^2": 1e-3, "ug/g^2": 1e-6},
    "third-order": {"g/g^3": 1.0, "ug/g^3": 1e-6},
    "fourth-order": {"g/g^4": 1.0, "ug/g^4": 1e-6},
    "time": {"s": 1.0, "min": 60.0, "h": 3600.0},
    "acceleration/time": {"g/s": 1.0, "ug/s": 1e-6, "ug/h": 1e-6 / 3600.0},
    "acceleration/field": {"g/mT": 1.0, "ug/mT": 1e-6, "ug/G": 1e-5},
}
"""Units of the quantities that specifications, reports and records state, by
dimension: each unit's size in the first unit of its dimension (``g`` for an
acceleration, ``1`` for a ratio or an angle). A unit ``X/degC`` or
``X/degC^k`` is a temperature coefficient of ``X``'s dimension."""


def unit_dimension(unit: str) -> str | None:
    """The dimension of ``unit`` (a key of :data:`UNIT_SIZES`, with ``/degC^k``), or None.

    ``"ug"`` is an ``"acceleration"``, ``"ppm/degC"`` a ``"ratio/degC"``.
    """
    base, per = _split_temperature(unit)
    for dimension, sizes in UNIT_SIZES.items():
        if base in sizes:
            return dimension + per
    return None


def convert(value, from_unit: str, to_unit: str):
    """``value`` in ``from_unit`` expressed in ``to_unit`` (same dimension).

    Raises
    ------
    ValueError
        When either unit is unknown or their dimensions differ.
    """
    dim_from, dim_to = unit_dimension(from_unit), unit_dimension(to_unit)
    if dim_from is None or dim_from != dim_to:
        raise ValueError(f"cannot convert {from_unit!r} to {to_unit!r}")
    sizes = UNIT_SIZES[dim_from.split("/degC", 1)[0]]
    return np.asarray(value, dtype=float) * (sizes[_split_temperature(from_unit)[0]]
                                             / sizes[_split_temperature(to_unit)[0]])


def _split_temperature(unit: str) -> tuple[str, str]:
    """``("ug", "/degC^2")`` for ``"ug/degC^2"``; ``(unit, "")`` for no temperature part."""
    base, sep, power = unit.rpartition("/degC")
    if sep and (power == "" or power in ("^2", "^3")):
        return base, sep + power
    return unit, ""
