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
:mod:`accelcal.io.formats.centrifuge`. The verbs every method package has:
:func:`simulate` (the rig), :func:`reduce` (a record, or its file, alone or
with a 1 g record: what ``accelcal centrifuge reduce`` does) and
:func:`plan`; ``reduce_centrifuge`` and ``reduce_joint`` stay as they were.

References
----------
.. [IEEE836] IEEE Std 836-2009, IEEE Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, sections 1 and 9.
"""

from accelcal.errors import AccelcalError
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
    "plan", "read_one_g", "reduce", "reduce_centrifuge", "reduce_joint", "report_text",
    "simulate", "specific_force",
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


def simulate(model, positions, levels, *, seed=None, **settings):
    """Simulate a centrifuge test: the rig's :func:`accelcal.rigs.centrifuge.simulate`.

    ``settings``: ``rig``, ``readings``, ``spinup``, ``noise``, ``survey``;
    ``seed`` an int, SeedSequence or Generator.
    """
    from accelcal.rigs.centrifuge import simulate as rig_simulate

    return rig_simulate(model, positions, levels, seed=seed, **settings)


def reduce(records, *, one_g=None, sensor: str | None = None, terms=None, estimate=None,
           sigma=None, rig_errors=None):
    """Reduce a centrifuge record (or its file), as ``accelcal centrifuge reduce`` does.

    Alone (:func:`reduce_centrifuge`, method ``centrifuge/lsq``) or, with a
    1 g record of the same sensor, jointly (:func:`reduce_joint`, method
    ``centrifuge/joint``, which also yields the radius error) [IEEE836]_.

    Parameters
    ----------
    records : accelcal.io.formats.centrifuge.CentrifugeRecord or path-like
    one_g : TumbleRecord, HeadRecord or path-like, optional
        The 1 g record (a file is read by :func:`read_one_g`).
    sensor : str, optional
        Sensor column of a dividing-head ``one_g``.
    terms : sequence of str, optional
        Terms to fit.
    estimate : sequence of str, optional
        Rig errors to estimate; default none alone, the radius error jointly.
    sigma : float, optional
        Known noise SD of one reading (alone only).
    rig_errors : mapping, optional
        Given rig errors, name -> ``(value, sd)`` (override the survey).

    Returns
    -------
    accelcal.results.Reduction
    """
    from os import PathLike

    if sensor is not None and one_g is None:
        raise AccelcalError("goes with a 1 g dividing-head record (one_g)", parameter="sensor")
    if sigma is not None and one_g is not None:
        raise AccelcalError("a joint reduction estimates each record's noise", parameter="sigma")
    record = records
    if isinstance(records, str | PathLike):
        from accelcal.io.formats import centrifuge as centrifuge_format

        record = centrifuge_format.read(records)
    if one_g is None:
        return reduce_centrifuge(record, terms=terms, estimate=estimate or (),
                                 rig_errors=rig_errors, sigma=sigma)
    if isinstance(one_g, str | PathLike):
        one_g = read_one_g(one_g)
    return reduce_joint(record, one_g, terms=terms, rig_errors=rig_errors, sensor=sensor,
                        estimate=("radius_error",) if estimate is None else estimate)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.io.formats import centrifuge
    from accelcal.method_ids import route_of

    if route_of(record.method) != "joint" or len(files) != 2:
        return []
    rec, one_g = centrifuge.read(files[0]), read_one_g(files[1])
    # the demo's rig estimate, then the command's default (tried only if the first does not fit)
    return ((reduce_joint(rec, one_g, estimate=estimate), {})
            for estimate in (("radius_error", "arm_stretch"), ("radius_error",)))
