"""Names, units and descriptions of the error model's coefficients.

A leaf module: the model (:mod:`accelcal.model`), its file format
(:mod:`accelcal.io.model_file`) and every method read the one table
:data:`TERMS`.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, model equation and coefficient units.
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021, eqs. (1)-(3).
"""

import difflib
from typing import NamedTuple


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
