"""Names, units and descriptions of the error model's coefficients.

A module on the floor above the ground floor (it imports only
:mod:`accelcal.errors` and :mod:`accelcal.validation`): the model
(:mod:`accelcal.model`), its file format (:mod:`accelcal.io.model_file`),
the physics and every method read the one table :data:`TERMS`.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, model equation and coefficient units.
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021, eqs. (1)-(3).
.. [DOMAIN] accelcal domain notes, section 8 (coefficients as polynomials in
   the sensor temperature about a reference T0).
"""

import difflib
import math
import numbers
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from accelcal.validation import shown


class Term(NamedTuple):
    """Description of one coefficient of :class:`ErrorModel`."""

    unit: str
    """Unit; ``{out}`` stands for the model's output unit."""
    description: str


TERMS: dict[str, Term] = {
    "K0": Term("g", "bias"),
    "K1": Term("{out}/g", "scale factor"),
    "K2": Term("g/g^2", "second-order nonlinearity"),
    "K3": Term("g/g^3", "third-order nonlinearity"),
    "K4": Term("g/g^4", "fourth-order nonlinearity"),
    "Ko": Term("g/g", "cross-axis sensitivity, output axis"),
    "Kp": Term("g/g", "cross-axis sensitivity, pendulum axis"),
    "Koo": Term("g/g^2", "cross-axis nonlinearity, output axis"),
    "Kpp": Term("g/g^2", "cross-axis nonlinearity, pendulum axis"),
    "Kio": Term("g/g^2", "cross-coupling, input x output axis"),
    "Kip": Term("g/g^2", "cross-coupling, input x pendulum axis"),
    "Kop": Term("g/g^2", "cross-coupling, output x pendulum axis"),
    "K0_asym": Term("g", "bias asymmetry K0'"),
    "K1_asym": Term("g/g", "scale-factor asymmetry K1'"),
    "sigma": Term("g", "output noise standard deviation"),
}
"""Every coefficient of the model, in the order used in files and tables.
These names are used everywhere: Python, files and the command line."""


def term_unit(name: str, output_unit: str) -> str:
    """Unit of term ``name`` for a model whose output is in ``output_unit``."""
    return TERMS[name].unit.format(out=output_unit)


def unknown_term_message(name: str, valid) -> str:
    """Message for an unknown coefficient name, with the closest valid names."""
    valid = list(valid)
    by_lower = {v.lower(): v for v in valid}
    close = [by_lower[c] for c in difflib.get_close_matches(name.lower(), list(by_lower), n=2)]
    hint = f" (did you mean {' or '.join(close)}?)" if close else ""
    return f"unknown term {name!r}{hint}; valid terms are: {', '.join(valid)}"


def unknown_term(name, valid=TERMS) -> str:
    """:func:`unknown_term_message`, with a user's name shown shortened.

    A name from a file or the command line may be a megabyte long or not a
    string at all; only a short printable one is matched to the valid names.
    """
    if isinstance(name, str) and len(name) <= 40 and name.isprintable():
        return unknown_term_message(name, valid)
    return f"unknown term {shown(name)}; valid terms are: {', '.join(valid)}"



# ----------------------------------------------------------------- temperature
TEMPERATURE_BASES: dict[str, str] = {"K0": "g", "K1": "1", "K2": "g/g^2", "Ko": "g/g",
                                     "Kp": "g/g"}
"""Terms that may vary with temperature, and the unit of their change per degC^k.
K1 varies relatively (``K1 (1 + sum c1_k dT^k)``: ``c1_k`` in 1/degC^k), the
others additively (``K + sum c_k dT^k``) [DOMAIN section 8]."""

MAX_TEMPERATURE_ORDER = 3
"""Highest power of (T - T0) a temperature polynomial may have."""

MIN_TEMPERATURE_DEGC = -273.15
"""Absolute zero: no temperature below it is accepted."""

MAX_TEMPERATURE_DEGC = 1000.0
"""Highest temperature accepted, degC (far beyond any accelerometer's range)."""

_ORDINAL = {1: "1st", 2: "2nd", 3: "3rd"}


def _temperature_unit(base: str, k: int) -> str:
    per = "degC" if k == 1 else f"degC^{k}"
    unit = TEMPERATURE_BASES[base]
    return f"1/{per}" if unit == "1" else f"{unit}/{per}"


TEMPERATURE_TERMS: dict[str, Term] = {
    f"{base}_T{k}": Term(_temperature_unit(base, k),
                         f"{_ORDINAL[k]}-order temperature coefficient of {base} "
                         f"({'relative, ' if base == 'K1' else ''}{TERMS[base].description})")
    for base in TEMPERATURE_BASES for k in range(1, MAX_TEMPERATURE_ORDER + 1)
}
"""Temperature coefficients ``<term>_T<k>``: the k-th power coefficient of the
term's polynomial in (T - T0), e.g. ``K0_T1`` (bias TC, g/degC), ``K1_T1``
(scale-factor TC, 1/degC: 1e-6 is 1 ppm/degC)."""


def temperature_term(name: str) -> tuple[str, int]:
    """``(base term, power)`` of a temperature coefficient name, e.g. ``("K1", 2)``."""
    base, _, k = name.rpartition("_T")
    return base, int(k)


def check_temperature(value, what: str = "temperature"):
    """``value`` as a float array of temperatures in degC; AccelcalError when not physical."""
    from accelcal.errors import AccelcalError

    t = np.asarray(value, dtype=float)
    if not np.isfinite(t).all() or (t.size and not (
            t.min() >= MIN_TEMPERATURE_DEGC and t.max() <= MAX_TEMPERATURE_DEGC)):
        raise AccelcalError(f"{what} must be finite temperatures in degC from "
                            f"{MIN_TEMPERATURE_DEGC:g} to {MAX_TEMPERATURE_DEGC:g}",
                            parameter="temperature")
    return t


@dataclass(frozen=True)
class TemperatureTerms:
    """The temperature dependence of an error model: polynomials in (T - T0).

    ``K(T) = K + sum_k K_Tk (T - T0)^k`` for K0, K2, Ko, Kp and
    ``K1(T) = K1 (1 + sum_k K1_Tk (T - T0)^k)`` for the scale factor, with T
    the sensor's temperature in degC [DOMAIN section 8].

    Parameters
    ----------
    reference : float
        T0, degC: the temperature at which the model's own terms hold.
    coefficients : mapping or tuple of (name, value)
        Names from :data:`TEMPERATURE_TERMS`; stored as ``(name, value)`` pairs
        in that table's order.
    valid_range : tuple of float, optional
        ``(low, high)`` in degC: the range the coefficients were determined
        over; evaluating outside it is refused. None: no stated range.

    References
    ----------
    .. [1] DOMAIN section 8; IEEE Std 1293-2018, thermal sensitivity of bias
       and scale factor.
    """

    reference: float
    coefficients: tuple = ()
    valid_range: tuple | None = None

    def __post_init__(self) -> None:
        from accelcal.errors import AccelcalError

        items = dict(self.coefficients.items() if hasattr(self.coefficients, "items")
                     else self.coefficients)
        for name, value in items.items():
            if name not in TEMPERATURE_TERMS:
                raise AccelcalError(unknown_term_message(str(name)[:40], TEMPERATURE_TERMS))
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(
                    value):
                raise AccelcalError(f"temperature coefficient {name} must be a finite number")
        ref = float(check_temperature(self.reference, "the reference temperature T0"))
        rng = self.valid_range
        if rng is not None:
            low, high = (float(v) for v in check_temperature(rng, "the valid range"))
            if not (np.shape(rng) == (2,) and low < high):
                raise AccelcalError("the valid temperature range must be (low, high) with low < "
                                    "high, degC")
            rng = (low, high)
        object.__setattr__(self, "reference", ref)
        object.__setattr__(self, "valid_range", rng)
        object.__setattr__(self, "coefficients", tuple(
            (n, float(items[n])) for n in TEMPERATURE_TERMS if n in items))

    def as_dict(self) -> dict[str, float]:
        """The coefficients by name."""
        return dict(self.coefficients)

    def units(self) -> dict[str, str]:
        """The unit of every coefficient given."""
        return {n: TEMPERATURE_TERMS[n].unit for n, _ in self.coefficients}

    def change(self, base: str, temperature):
        """``sum_k c_k (T - T0)^k`` of term ``base`` (relative for K1), Horner form.

        Raises
        ------
        AccelcalError
            For temperatures that are not finite or outside :attr:`valid_range`.
        """
        from accelcal.errors import AccelcalError

        t = check_temperature(temperature)
        if self.valid_range is not None and t.size and (
                t.min() < self.valid_range[0] or t.max() > self.valid_range[1]):
            raise AccelcalError(
                f"temperature {t.min() if t.min() < self.valid_range[0] else t.max():.6g} degC "
                f"is outside the model's valid range {self.valid_range[0]:g} to "
                f"{self.valid_range[1]:g} degC (the range its coefficients were determined "
                "over)", parameter="temperature")
        c = self.as_dict()
        dt = t - self.reference
        out = np.zeros_like(dt)
        for k in range(MAX_TEMPERATURE_ORDER, 0, -1):  # Eq. (8.1) [DOMAIN], Horner form
            out = (out + c.get(f"{base}_T{k}", 0.0)) * dt
        return out

    def apply(self, terms: dict, temperature) -> dict:
        """``terms`` (name -> value at T0) evaluated at ``temperature`` (degC): a new dict."""
        out = dict(terms)
        for base in self.bases():
            change = self.change(base, temperature)
            # Eq. (8.1)-(8.2) [DOMAIN]: relative for the scale factor, additive otherwise.
            out[base] = out[base] * (1.0 + change) if base == "K1" else out[base] + change
        return out

    def bases(self) -> tuple[str, ...]:
        """The terms with a temperature coefficient, in :data:`TEMPERATURE_BASES` order."""
        given = {temperature_term(n)[0] for n, _ in self.coefficients}
        return tuple(b for b in TEMPERATURE_BASES if b in given)
