"""Precision centrifuge testing (IEEE 836): rig errors, reduction of K2, K3, K4 and cross-coupling.

The accelerometer sits on a horizontal arm in several positions (IA radial
inward and outward, OA or PA radial, IA tangential, any orientation by
three angles) at several levels ``Omega^2 R / g``. The package:

:mod:`~accelcal.physics.centrifuge`
    Below the package, shared with the rig: specific force on the arm
    (DOMAIN section 9), positions, regressors (re-exported here).
:mod:`~accelcal.methods.centrifuge.core`
    Observation blocks and the Gauss-Newton weighted least squares with the
    rig errors given (propagated) or estimated.
:mod:`~accelcal.methods.centrifuge.identify`
    :func:`identifiability`: what a design separates (radius error vs K1).
:mod:`~accelcal.methods.centrifuge.reduce`
    :func:`reduce_centrifuge` (method ``"centrifuge/lsq"``).
:mod:`~accelcal.methods.centrifuge.joint`
    :func:`reduce_joint` with a 1 g record (method ``"centrifuge/joint"``).
:mod:`~accelcal.methods.centrifuge.plan`
    :func:`plan`: predicted uncertainties without data; ``mc`` confirms them.
:mod:`~accelcal.methods.centrifuge.figures`
    Output against level per position, residuals.

The rig is :mod:`accelcal.rigs.centrifuge`, the record format
:mod:`accelcal.io.formats.centrifuge`.

References
----------
.. [IEEE836] IEEE Std 836-2009, IEEE Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, sections 1 and 9.
"""

from accelcal.methods import ReportText
from accelcal.methods.centrifuge.figures import figures
from accelcal.methods.centrifuge.identify import CentrifugeIdentifiability, identifiability
from accelcal.methods.centrifuge.joint import read_one_g, reduce_joint
from accelcal.methods.centrifuge.plan import CentrifugePlan, plan
from accelcal.methods.centrifuge.reduce import FAMILY, reduce_centrifuge
from accelcal.physics.centrifuge import (
    ASYMMETRY_TERMS,
    FULL_TERMS,
    POSITIONS,
    RIG_ERRORS,
    orientation,
    specific_force,
)

__all__ = [
    "ASYMMETRY_TERMS", "ERRATA", "FAMILY", "FULL_TERMS", "POSITIONS", "RIG_ERRORS",
    "CentrifugeIdentifiability", "CentrifugePlan", "figures", "identifiability", "orientation",
    "plan", "read_one_g", "reduce_centrifuge", "reduce_joint", "report_text", "specific_force",
]

ERRATA = (
    ("A radius error cannot be told apart from K1 only while gravity never projects on IA: a "
     "position with IA vertical (OA or PA radial) and K0 from the IA-horizontal positions "
     "calibrate K1 at 1 g, so the centrifuge alone then separates the radius error (weakly); "
     "accelcal computes what each design separates instead of assuming it."),
    ("A proof-mass offset along IA changes the radius by -d (i . r): with IA inward and outward "
     "it looks exactly like scale-factor asymmetry K1' (both even and linear in the level), "
     "so the two are never estimated together."),
)
"""Precisions of DOMAIN section 9 (docs/centrifuge.md, docs/errata.md)."""


def report_text(reduction) -> ReportText:
    """The report's title and summary of a centrifuge reduction."""
    prov = reduction.provenance
    joint = reduction.method.endswith("joint")
    rig = ", ".join(prov.get("estimated", [])) or "none (all given from the survey)"
    return ReportText(
        title="Precision centrifuge (IEEE 836)",
        summary=(f"Centrifuge test at radius {prov.get('radius_m', float('nan')):g} m: "
                 f"{prov.get('steps', 0)} steps in positions {', '.join(prov.get('positions', []))}"
                 + (", reduced jointly with a 1 g record of the same sensor" if joint else "")
                 + f". Weighted least squares on the exact arm geometry; rig errors estimated: "
                 f"{rig}; the others given with their uncertainty, propagated."),
        sensor_summary="Model E = K1 (K0 + a_i + K2 a_i² + K3 a_i³ + K4 a_i⁴ + cross terms "
                       "+ asymmetry), a = C f with f = Ω² R r + g z.",
        paper="IEEE836",
    )
