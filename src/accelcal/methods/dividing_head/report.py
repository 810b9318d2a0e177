"""What a report says about an indexing-head reduction, and Dong2014's errata.

Built from the :class:`~accelcal.results.Reduction`'s fields: the method,
the number of sensors and positions, whether the head error was separated
(``shared``, or its values in ``observations`` for many positions), and
the null space of the joint design (``identifiability``: unknowns minus
rank).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
"""

from accelcal.methods import ReportText
from accelcal.methods.dividing_head.figures import head_error
from accelcal.methods.dividing_head.theory import method_name

ERRATA = (
    ("Eqs. (15), (18), (21) and (25)-(28) carry misprinted terms (K'_IO for K'_II, missing "
     "eta and K'_F3 terms, mixed angle frames); the corrected expansions are used."),
    ("The mean head error and the mounting misalignment cannot be separated from K_O by the "
     "accelerometers alone: K_O is reported as K_O* = K_O + K_I (eta + d0)."),
    ("The first harmonic of the head error is not negligible: unless it is measured it "
     "biases K_F, K_IO and K_II by about K_I |d1|; the notes say how it was treated."),
    "Each sensor is normalised by its own fitted scale factor, not the nominal one.",
)
"""Dong2014's errata a report shows (entries in docs/errata.md)."""


def report_text(reduction) -> ReportText:
    """Title and summary of an indexing-head reduction's report section.

    References
    ----------
    .. [1] Dong2014, eq. (5) and Tables 1-2 (coefficients and their SDs).
    """
    method = method_name(reduction)
    k = reduction.n_sensors
    n = len(reduction.observations["positions"])
    who = f"{k} accelerometers" if k > 1 else "One accelerometer"
    separated = head_error(reduction) is not None
    summary = (f"{who} on an indexing head at {n} positions, reduced "
               f"{'together ' if separated else ''}(method {method}). "
               "Estimates ± standard uncertainty (1 σ); ")
    if separated:
        summary += "the head's angular position error is separated from the sensors' coefficients."
    else:
        summary += ("the head's angular position error is not modelled: it biases the "
                    "coefficients and inflates the residuals.")
    ident = reduction.identifiability
    if ident is not None:
        dim = len(ident.names) - ident.rank
        summary += (f" The unconstrained joint design has a {dim}-dimensional null space: the "
                    "mean head error (indistinguishable from a common K_O offset) and its first "
                    "harmonic (indistinguishable from K_F, K_IO, K_II offsets)"
                    f"{'' if dim <= 3 else ', and more: the sensors lie on one line'}; "
                    "the notes say how that gauge is fixed.")
    if k > 1:
        summary += (" Each sensor's record, with expanded uncertainties and correlations, is "
                    "in the appendix.")
    return ReportText(
        title=f"Indexing head: {k} sensor{'s' if k > 1 else ''}, method {method}",
        summary=summary,
        sensor_summary=("Model U = K_F + K_I a_i + K_O a_o + K_IO a_i a_o + K_II a_i² "
                        "(Dong2014 eq. (5)); K_O is K_O* = K_O + K_I (eta + d0)."),
        paper="Dong2014",
    )
