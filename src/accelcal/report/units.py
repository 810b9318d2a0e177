"""Every reported coefficient in the units people who read calibrations compare.

:func:`accelcal.engineering.engineering` converts the coefficients of the
error model by name (µg, ppm, µrad, µg/g²). A report shows every
coefficient of every method, so this module extends it for the report:

* a name the table does not know is read by its parts (``K0_hyst`` is a
  bias, ``Kp_hyst`` a misalignment, ``warmup_K0`` a bias), then by its unit
  (``g`` -> µg, ``g/g^2`` -> µg/g², ``rad`` -> µrad, ``1`` -> ppm,
  ``g*sqrt(s)`` -> µg/√Hz, ``g/sqrt(s)`` -> µg/√s);
* a triad's bias in counts becomes µg through the same axis's scale factor
  (``b_x s_x`` is the bias in m/s², Tedaldi2014 eq. (8));
* a scale factor without a nominal value keeps its unit (a triad's m/s² per
  count becomes µg per count) and states its uncertainty relative to
  itself, in ppm (IEEE 1293's scale-factor stability is quoted so);
* anything else (a time constant in s) stays in its own unit, which is then
  the field's.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex A (units of the model coefficients).
.. [IEEE952] IEEE Std 952-1997, annex C (the noise coefficients' units: N
   in g/√Hz, K in g/√s).
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, eq. (8).
"""

import math
import re
from dataclasses import dataclass

from accelcal.engineering import QUANTITIES, engineering
from accelcal.formatting import format_std, format_unit, format_value
from accelcal.units import STANDARD_GRAVITY

_BY_UNIT = {"g": "bias", "m/s^2": "bias", "mg": "bias", "ug": "bias", "rad": "misalignment",
            "1": "ratio", "g/g": "ratio", "g/g^2": "second", "g/g^3": "third",
            "g/g^4": "fourth"}
"""Quantity of a coefficient whose name says nothing, by its unit."""

_NOISE = {"g*sqrt(s)": "ug/sqrt(Hz)", "g/sqrt(s)": "ug/sqrt(s)", "g/sqrt(Hz)": "ug/sqrt(Hz)"}
"""Noise coefficients in g-based units -> their µg form (x 1e6) [IEEE952]."""

_PER_COUNT = "(m/s^2)/(count"
"""A triad's scale factor in m/s² per count (``(m/s^2)/(counts)``)."""

_TRIAD = re.compile(r"(?P<kind>[bsa])_(?P<axis>[xyz])[xyz]?")


@dataclass(frozen=True)
class FieldValue:
    """A coefficient in a field unit.

    ``relative`` marks a scale factor without a nominal: ``estimate`` is in
    ``unit`` and ``std`` in ppm of the estimate.
    """

    estimate: float
    std: float
    unit: str
    relative: bool = False

    def text(self, k: float = 1.0) -> str:
        """``estimate ± k std unit`` (``estimate unit ± k std ppm`` when relative)."""
        u = k * self.std
        if self.relative:
            digits = format_value(self.estimate, abs(self.estimate) * self.std * 1e-6)
            return f"{digits} {format_unit(self.unit)} ± {format_std(u)} ppm"
        return (f"{format_value(self.estimate, self.std)} ± {format_std(u)} "
                f"{format_unit(self.unit)}")


SMALL = 1e-2
"""A coefficient known by its unit alone (``g``, ``1``) is shown in µg or ppm below this
magnitude (a bias, a ratio); above it (an input range of 30 g, a response of 1.0) it
keeps its unit."""


def quantity_of(name: str, unit: str) -> str | None:
    """The quantity of a coefficient (:data:`accelcal.engineering.QUANTITIES` keys' values).

    By its name (:func:`named_quantity`), then by its unit. None when
    nothing applies.
    """
    return named_quantity(name, unit) or _BY_UNIT.get(unit)


def named_quantity(name: str, unit: str) -> str | None:
    """The quantity a coefficient's name says, or None.

    By its name, the first term of a combination (``K_F+K_OO``), the parts
    of its name (split at ``_``, ``+``, ``-``); a triad's ``b_x``, ``s_x``,
    ``a_yz`` are a bias, a scale factor and a misalignment.
    """
    if name in QUANTITIES:
        return QUANTITIES[name]
    triad = _TRIAD.fullmatch(name)
    if triad:
        return {"b": "bias", "s": "scale", "a": "misalignment"}[triad["kind"]]
    first = re.split(r"[+\-]", name)[0]  # a combination's label: K_F+K_OO is a bias
    if first in QUANTITIES:
        return QUANTITIES[first]
    for part in re.split(r"[_+\-]", name):
        kind = QUANTITIES.get(part)
        if kind is not None and "/" not in kind:
            return "ratio" if kind == "scale" and unit in ("1", "") else kind
    return None


def field_values(name: str, estimate: float, std: float, unit: str, *,
                 scale_factor=None, axis_scale=None, quantity=None, nominal=None
                 ) -> tuple[FieldValue, ...]:
    """``name`` in its field units: one or more :class:`FieldValue`, never none.

    Parameters
    ----------
    name, estimate, std, unit
        The coefficient as a record holds it.
    scale_factor : float, optional
        The sensor's scale factor in output unit per g (output-unit coefficients).
    axis_scale : float, optional
        A triad axis's scale factor in m/s² per count (its bias in counts).
    quantity : str, optional
        Override of the quantity (a reduction's ``quantities``).
    nominal : float, optional
        Nominal scale factor for a ppm deviation.
    """
    if not math.isfinite(estimate):
        return (FieldValue(estimate, std, unit),)
    kind = quantity or named_quantity(name, unit)
    if kind is None and abs(estimate) < SMALL:
        kind = _BY_UNIT.get(unit)
    if kind == "bias" and unit == "counts" and axis_scale:
        estimate, std, unit = estimate * axis_scale, std * abs(axis_scale), "m/s^2"
    if kind is not None and kind != "scale" and kind.split("/")[0] in _KINDS:
        found = engineering(name, estimate, std, unit, scale_factor=scale_factor,
                            quantity=kind)
        if found:
            return tuple(FieldValue(e.estimate, e.std, e.unit) for e in found)
    if kind == "scale":
        found = engineering(name, estimate, std, unit, nominal=nominal, quantity=kind)
        if found:
            return tuple(FieldValue(e.estimate, e.std, e.unit) for e in found)
        if estimate != 0:
            relative = std / abs(estimate) * 1e6
            if unit.startswith(_PER_COUNT):  # a triad's: in µg per count
                estimate, unit = estimate / STANDARD_GRAVITY * 1e6, "ug/count"
            return (FieldValue(estimate, relative, unit, relative=True),)
    if unit in _NOISE:
        return (FieldValue(estimate * 1e6, std * 1e6, _NOISE[unit]),)
    return (FieldValue(estimate, std, unit),)


_KINDS = ("bias", "ratio", "misalignment", "transverse", "second", "third", "fourth")


def record_field_values(record) -> list[tuple[FieldValue, ...]]:
    """Each of a record's coefficients in its field units (:func:`field_values`).

    Output-unit coefficients are normalised by the record's scale factor
    (``K_I`` or ``K1``, else its error model's); a triad's biases by their
    axis's scale factor. A complex coefficient keeps its unit (magnitude).
    """
    names = list(record.names)
    values = dict(zip(names, (float(abs(v)) if record.is_complex else float(v)
                              for v in record.estimates), strict=True))
    std = dict(zip(names, (float(s) for s in coefficient_std(record)), strict=True))
    k1 = next((values[n] for n in ("K_I", "K1") if n in values), None)
    if k1 is None and record.model is not None and not record.is_complex:
        k1 = float(record.model.K1)
    out = []
    for n in names:
        plain = record.plain.get(n, n)
        triad = _TRIAD.fullmatch(plain)
        axis_scale = (values.get(f"s_{triad['axis']}") if triad and triad["kind"] == "b"
                      else None)
        out.append(field_values(plain, values[n], std[n], record.units.get(n, ""),
                                scale_factor=k1, axis_scale=axis_scale))
    return out


def coefficient_std(record):
    """A record's standard uncertainties (of the magnitude for a complex coefficient)."""
    if not record.is_complex:
        return record.std
    return record.polar().magnitude_std
