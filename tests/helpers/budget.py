"""Inputs of the budget tests: lab files written from a few standards, small tumble records."""

import numpy as np

LAB_HEAD = """
[laboratory]
name = "Test laboratory"
address = "Somewhere"
accreditation = "X-0001"

[[signatory]]
name = "A. Person"
role = "Head"

[environment]
temperature_degC = 23.0
"""


def standard(quantity, value, unit, due="2099-01-01", **uncertainty) -> str:
    """One ``[[standard]]`` table (uncertainty keys as given: u=, U= and k=, bounds=...)."""
    lines = ["[[standard]]", f'quantity = "{quantity}"', f"value = {value}", f'unit = "{unit}"']
    for key, v in uncertainty.items():
        lines.append(f'{key} = "{v}"' if isinstance(v, str) else f"{key} = {v}")
    lines.append(f"due = {due}")
    return "\n".join(lines) + "\n"


def lab_text(*standards: str, extra: str = "") -> str:
    """A lab file of the given standards."""
    return LAB_HEAD + "\n" + "\n".join(standards) + extra


def linear_tumble(n: int = 12, k1: float = 1.3, k0: float = 5e-4, unit: str = "V"):
    """A noiseless tumble record of ``E = K1 (K0 + cos theta)`` at ``n`` uniform positions."""
    from accelcal.io.formats.tumble import TumbleRecord

    theta = 2 * np.pi * np.arange(n) / n
    return TumbleRecord(theta, k1 * (k0 + np.cos(theta)), "OA", unit)
