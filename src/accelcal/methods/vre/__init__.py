"""Vibration rectification error (VRE) with asymmetry under overload and vibration (Guan2021).

A vibrafuge (centrifuge plus shaker) holds an accelerometer under an
overload while it vibrates; the VRE is the whole-period mean of the output
while vibrating minus the mean at rest, in g. The package:

:mod:`~accelcal.methods.vre.closed_form`
    The closed forms (Guan2021 eqs. (9), (21)-(25), and the vector case):
    :func:`sgn_shape`, :func:`even_order_vre`, :func:`asymmetry_vre`,
    :func:`relative_error`, :func:`vre_table`, :func:`vre_columns`,
    :func:`vector_vre`.
:mod:`~accelcal.methods.vre.measure`
    :func:`reduce_run`: vibrafuge records to measured VRE with uncertainty;
    :func:`sampled_columns`: the design of point-sampled records, exact.
:mod:`~accelcal.methods.vre.identify`
    :func:`identify`: the coefficients from measured VRE, as a
    :class:`~accelcal.results.Reduction` (family ``"vre"``, method
    ``"vre/identify"``).
:mod:`~accelcal.methods.vre.mc`
    :func:`vre_uncertainty`: Monte Carlo (GUM-S1) uncertainty of an
    identification.
:mod:`~accelcal.methods.vre.figures`
    :func:`figures` of an identification; :func:`table_figures`, the
    paper's Figs. 2-4.

Record files of kind ``vibrafuge`` are :mod:`accelcal.io.formats.vibrafuge`;
the simulator is :mod:`accelcal.rigs.vibrafuge`.

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (1)-(25), Table 1, Figs. 2-4.
"""

from accelcal.methods import ReportText
from accelcal.methods.vre.closed_form import (
    PAPER_TERMS,
    VRE_TERMS,
    VreTable,
    along_ia,
    asymmetry_vre,
    even_order_vre,
    relative_error,
    sgn_shape,
    vector_vre,
    vre_columns,
    vre_table,
)
from accelcal.methods.vre.figures import figures, table_figures
from accelcal.methods.vre.identify import FAMILY, METHOD, identify
from accelcal.methods.vre.mc import VreSampler, vre_uncertainty
from accelcal.methods.vre.measure import HARMONICS, VreMeasurement, reduce_run, sampled_columns

__all__ = [
    "ERRATA", "FAMILY", "HARMONICS", "METHOD", "PAPER_TERMS", "VRE_TERMS", "VreMeasurement",
    "VreSampler", "VreTable", "along_ia", "asymmetry_vre", "even_order_vre", "figures",
    "identify", "reduce_run", "relative_error", "report_text", "sampled_columns", "sgn_shape",
    "table_figures",
    "vector_vre", "vre_columns", "vre_table", "vre_uncertainty",
]

ERRATA = (
    ("\"Without loss of generality, b > 0\" does not hold: the asymmetry VRE is odd in b "
     "for K0' and even for K1'; the closed form used holds for either sign of the overload."),
    ("Ko and Kp are in g/g (the paper's symbol list says V/g); the fourth-order term K4 is "
     "kept."),
)
"""Corrections of Guan2021 a report shows (entries in docs/errata.md)."""


def report_text(reduction) -> ReportText:
    """Title and summary of a VRE identification's report section."""
    n = len(reduction.observations["vre"])
    weighted = reduction.assumed("weighting") == "uncertainty"
    how = "weighted least squares" if weighted else "least squares"
    return ReportText(
        title="vibration rectification (vibrafuge)",
        summary=(f"Vibration rectification error under overload b along IA and sinusoidal "
                 f"vibration of amplitude A, {n} test points (overload, amplitude); "
                 f"coefficients by {how} (Guan2021, asymmetry included)."),
        paper="Guan2021",
    )
