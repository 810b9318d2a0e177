"""Coefficients in the units inertial engineers read: µg, ppm, µg/g², µrad, arcsec.

A reduction returns coefficients in the units of the model it fits: the
output unit (V, V/g, V/g² in Dong2014's notation), or g-normalised (g,
g/g, g/g^n in IEEE 1293's). People who read calibrations compare them in
the field's units (IEEE Std 1293-2018 annex A, data-sheet practice):

==================  =====================================  ====================
quantity            coefficients                           engineering units
==================  =====================================  ====================
bias                K0, K_F, K0_asym                       µg
scale factor        K1, K_I (with a nominal given)         ppm deviation
ratio               K1_asym                                ppm
misalignment        Ko, Kp, K_O, K_P                       µrad and arcsec
transverse          Ko, Kp of a shaker test                mg/g
second order        K2, K_II, Kio, Kip, Kop, Koo, Kpp,     µg/g²
                    K_IO
third order         K3                                     µg/g³
fourth order        K4                                     µg/g⁴
bias TC             K0_T1, K0_T2, K0_T3                    µg/°C, µg/°C², µg/°C³
scale-factor TC     K1_T1, K1_T2, K1_T3 (relative)         ppm/°C, ppm/°C², ...
misalignment TC     Ko_Tk, Kp_Tk                           µrad/°C^k
second-order TC     K2_Tk                                  µg/g²/°C^k
==================  =====================================  ====================

A bias in an acceleration unit (m/s², mg, µg: a triad's) is converted to g
with the conventional g_n. A coefficient in an output unit (``V``, ``V/g``,
``V/g^2``, ...) is first
divided by the same sensor's scale factor (``K_I`` or ``K1`` in output unit
per g), so ``K_F / K_I`` is the bias in g [Dong2014 eq. (5)]; the
uncertainty of that scale factor (relative order 1e-6 against the others'
1e-2 and above) is neglected in the converted standard uncertainty, which
is the raw one divided by the same factor.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, IEEE Specification Format Guide and Test
   Procedure for Linear Single-Axis, Nongyroscopic Accelerometers, sec. 4
   and annex A (units of the model coefficients).
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
"""

import math
from dataclasses import dataclass

from accelcal.units import ARCSEC, OUTPUT_UNITS, STANDARD_GRAVITY

QUANTITIES = {
    "K0": "bias", "K_F": "bias", "K0_asym": "bias",
    "K1": "scale", "K_I": "scale",
    "K1_asym": "ratio",
    "Ko": "misalignment", "Kp": "misalignment", "K_O": "misalignment", "K_P": "misalignment",
    "K2": "second", "K_II": "second", "K_IO": "second", "Kio": "second", "Kip": "second",
    "Kop": "second", "Koo": "second", "Kpp": "second",
    "K3": "third", "K4": "fourth",
}
for _k in (1, 2, 3):
    QUANTITIES |= {f"K0_T{_k}": f"bias/T{_k}", f"K1_T{_k}": f"ratio/T{_k}",
                   f"Ko_T{_k}": f"misalignment/T{_k}", f"Kp_T{_k}": f"misalignment/T{_k}",
                   f"K2_T{_k}": f"second/T{_k}"}
"""Quantity of each coefficient name (a reduction may override per coefficient);
``<quantity>/T<k>`` is its k-th temperature coefficient (per degC^k)."""

_SCALES = {
    "bias": (("ug", 1e6),),
    "ratio": (("ppm", 1e6),),
    "misalignment": (("urad", 1e6), ("arcsec", 1.0 / ARCSEC)),
    "transverse": (("mg/g", 1e3),),
    "second": (("ug/g^2", 1e6),),
    "third": (("ug/g^3", 1e6),),
    "fourth": (("ug/g^4", 1e6),),
}
for _k in (1, 2, 3):
    _per = "degC" if _k == 1 else f"degC^{_k}"
    _SCALES |= {f"{q}/T{_k}": tuple((f"{u}/{_per}", f) for u, f in _SCALES[q])
                for q in ("bias", "ratio", "misalignment", "second")}


_ACCELERATION_IN_G = {"g": 1.0, "m/s^2": 1.0 / STANDARD_GRAVITY, "mg": 1e-3, "ug": 1e-6}
"""Size in g of the acceleration units a bias may be given in (g_n: a unit conversion)."""


@dataclass(frozen=True)
class Engineering:
    """One coefficient in one engineering unit."""

    estimate: float
    std: float
    unit: str

    def as_dict(self) -> dict:
        """``{"estimate", "std", "unit"}``."""
        return {"estimate": self.estimate, "std": self.std, "unit": self.unit}


def is_output_unit(unit: str) -> bool:
    """True for a unit whose numerator is an output unit (V, mV, mA), e.g. ``V/g^2``."""
    return unit.split("/", maxsplit=1)[0] in OUTPUT_UNITS and unit.split("/", maxsplit=1)[0] != "g"


def engineering(name: str, estimate: float, std: float, unit: str, *, scale_factor=None,
                nominal=None, quantity: str | None = None) -> tuple[Engineering, ...]:
    """A coefficient in its engineering units (empty when none applies).

    Parameters
    ----------
    name : str
        Coefficient name (looked up in :data:`QUANTITIES` unless ``quantity``).
    estimate, std : float
        Value and standard uncertainty in ``unit``.
    unit : str
        The coefficient's unit.
    scale_factor : float, optional
        The sensor's scale factor in output unit per g, to normalise
        output-unit coefficients; without it they get no engineering units.
    nominal : float, optional
        Nominal scale factor (same unit as the estimate) for the ppm deviation.
    quantity : str, optional
        Override of the quantity (``"transverse"`` for a shaker test's Ko, Kp).

    Returns
    -------
    tuple of Engineering
    """
    kind = quantity or QUANTITIES.get(name)
    if kind is None or not math.isfinite(estimate):
        return ()
    if kind == "scale":
        if nominal is None or nominal == 0 or not math.isfinite(nominal):
            return ()
        return (Engineering((estimate - nominal) / nominal * 1e6, std / abs(nominal) * 1e6,
                            "ppm"),)
    if kind == "bias" and unit in _ACCELERATION_IN_G:  # a triad's bias in m/s^2, mg, ...
        estimate, std = estimate * _ACCELERATION_IN_G[unit], std * _ACCELERATION_IN_G[unit]
    elif is_output_unit(unit):
        if scale_factor is None or scale_factor == 0 or not math.isfinite(scale_factor):
            return ()
        estimate, std = estimate / scale_factor, std / abs(scale_factor)
    return tuple(Engineering(estimate * f, std * f, u) for u, f in _SCALES[kind])
