"""Accelerometer triad on static positions: bias, scale factor, non-orthogonality (issue 12).

Three accelerometers in one housing are calibrated as a unit from the
means of static intervals, by two routes:

:mod:`~accelcal.methods.triad.model`
    :class:`TriadCalibration` (``a = T (p + q ⊙ p²)``, ``p = K (u - b)``;
    Tedaldi's triangular ``T``), :data:`PARAMS`, :data:`QUADRATIC`; JSON and
    imucal's ``K_a, R_a, b_a`` layout both ways.
:mod:`~accelcal.physics.gravity`
    Below the package, shared with the rig: :func:`normal_gravity` (WGS84,
    Somigliana, free-air height term), re-exported here.
:mod:`~accelcal.methods.triad.known`
    :func:`calibrate_known`: known orientations (six-position Ferraris,
    turntable), linear least squares and an RQ split (method
    ``"triad/known-orientations"``).
:mod:`~accelcal.methods.triad.unknown`
    :func:`calibrate_unknown`: unknown orientations, the gravity-norm
    nonlinear least squares (method ``"triad/gravity-norm"``).
:mod:`~accelcal.methods.triad.identify`
    :func:`plan`: what a position set determines, before reducing.
:mod:`~accelcal.methods.triad.mc`
    :func:`triad_uncertainty`: Monte Carlo (GUM-S1) uncertainty.
:mod:`~accelcal.methods.triad.figures`
    :func:`figures`: norm residuals before/after, position directions.

Static-interval detection (``static``) and the imucal session reader
(``imucal``) are further modules of the package.

The verbs every method package has: :func:`simulate` (the rig),
:func:`reduce` (a recording to a Reduction), :func:`uncertainty` (Monte
Carlo) and :func:`plan` (a design of positions before the test);
:func:`run` (:mod:`~accelcal.methods.triad.lab`) is the lab's path of
``accelcal triad calibrate`` in one call. ``calibrate_known``,
``calibrate_unknown`` (on interval means) and ``triad_uncertainty`` stay
as they were. The rig simulator is
:mod:`accelcal.rigs.triad`, the record format :mod:`accelcal.io.formats.triad`.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., "A robust and easy to
   implement method for IMU calibration without external equipments", ICRA
   2014.
.. [Ferraris1995] Ferraris F., Grimaldi U., Parvis M., "Procedure for
   effortless in-field calibration of three-axis rate gyros and
   accelerometers", Sensors and Materials 7(5), 1995.
.. [TR8350.2] NIMA TR8350.2, World Geodetic System 1984, 3rd ed., 2000.
"""

from accelcal.methods import ReportText
from accelcal.methods.triad.common import FAMILY, calibration_of, norm_residuals
from accelcal.methods.triad.figures import figures
from accelcal.methods.triad.identify import Plan, plan
from accelcal.methods.triad.known import METHOD as KNOWN_METHOD
from accelcal.methods.triad.known import calibrate_known
from accelcal.methods.triad.lab import TriadRun, run
from accelcal.methods.triad.mc import TriadSampler, triad_uncertainty
from accelcal.methods.triad.model import PARAMS, QUADRATIC, TriadCalibration
from accelcal.methods.triad.result import GAUGE
from accelcal.methods.triad.unknown import METHOD as UNKNOWN_METHOD
from accelcal.methods.triad.unknown import calibrate_unknown
from accelcal.physics.gravity import normal_gravity

__all__ = [
    "ERRATA", "FAMILY", "GAUGE", "KNOWN_METHOD", "PARAMS", "QUADRATIC", "UNKNOWN_METHOD", "Plan",
    "TriadCalibration", "TriadRun", "TriadSampler", "calibrate_known", "calibrate_unknown",
    "calibration_of", "figures", "norm_residuals", "normal_gravity", "plan", "reduce",
    "report_text", "run", "simulate", "triad_uncertainty", "uncertainty",
]

ERRATA = (
    ("Body frame of Tedaldi's upper-triangular T: an accelerometer reads projections n_i·a, so "
     "the sensor axes are the rows of T⁻¹ (normalised): z_body lies along the sensor z axis and "
     "y_body in the sensor y-z plane, not x_body along sensor x with y_body in the x-y plane "
     "(that statement fits the lower-triangular form). Derived and tested; accelcal keeps the "
     "upper-triangular T with this frame."),
    ("The gravity norm does not fix the polarity of an axis (s_i → −s_i with the angles it "
     "enters and q_i) nor the rotation of the body frame; accelcal reports positive scale "
     "factors and the triangular frame above."),
    ("Known orientations: the readings are fitted as functions of the known specific force "
     "(u = A f + b, noise in u), and A = K⁻¹ T⁻¹ Q split by RQ; the fixture-to-body rotation Q "
     "is a gauge, reported as three angles, not a sensor parameter."),
)
"""Corrections and precisions of Tedaldi2014 / DOMAIN section 6 (docs/triad.md, docs/errata.md)."""


def report_text(reduction) -> ReportText:
    """The report's title and summary of a triad calibration."""
    n = reduction.provenance.get("positions", 0)
    unit = reduction.provenance.get("input_unit", "")
    quad = " with per-axis quadratic terms" if reduction.provenance.get("quadratic") else ""
    if reduction.method == KNOWN_METHOD:
        how = (f"{n} positions of known orientation: linear least squares on the readings and "
               "an RQ split into scale factors, non-orthogonality angles and the fixture "
               "rotation (a gauge)")
    else:
        how = (f"{n} static positions of unknown orientation: gravity-norm nonlinear least "
               "squares (Levenberg-Marquardt)")
    route = "known orientations" if reduction.method == KNOWN_METHOD else "gravity norm"
    return ReportText(
        title=f"Accelerometer triad on static positions ({route})",
        summary=(f"Triad calibration from {how}{quad}; raw output in {unit}, specific force in "
                 f"m/s² at local gravity {reduction.provenance.get('gravity', float('nan')):.7g} "
                 "m/s²; first-order covariance."),
        sensor_summary="Model a = T (p + q p²), p = diag(s) (u − b), T upper triangular "
                       "(Tedaldi).",
        paper="Tedaldi2014",
    )


def simulate(calibration, up, *, seed=None, **settings):
    """A triad recording of ``calibration`` through static positions ``up``.

    The rig's simulation, :func:`accelcal.rigs.triad.simulate` (``settings``:
    ``rate``, ``dwell``, ``motion``, ``still``, ``noise_sd``, ``gravity``,
    ``lever_arm``, ``labels``); ``seed`` an int, SeedSequence or Generator.
    """
    from accelcal.rigs.triad import simulate as rig_simulate

    return rig_simulate(calibration, up, seed=seed, **settings)


def reduce(records, **options):
    """The calibration of a triad recording (path or Recording), as ``triad calibrate``.

    :func:`run` (route, static detection, gravity) and its Reduction;
    ``options`` are :func:`run`'s.
    """
    return run(records, **options).reduction


def uncertainty(reduction, *, trials: int, seed: int, **options):
    """Monte Carlo (GUM-S1) uncertainty of a triad calibration: :func:`triad_uncertainty`."""
    return triad_uncertainty(reduction, trials=trials, seed=seed, **options)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.io.formats import triad
    from accelcal.method_ids import route_of
    from accelcal.methods.triad.lab import run
    from accelcal.signal.static import detect_static

    known = route_of(record.method) == "known-orientations"

    def candidates():  # the demo's reduction of a triad record, then the command's path
        rec = triad.read(files[0])
        g = rec.metadata["gravity"]
        if known:
            means, counts = rec.interval_means()
            yield calibrate_known(means, rec.up, g, input_unit=rec.input_unit,
                                  labels=rec.labels, counts=counts), {}
        else:
            found = detect_static(rec.acc, rec.metadata["rate"], init_static=30.0,
                                  unit=rec.input_unit)
            yield (calibrate_unknown(found.means, g, input_unit=rec.input_unit,
                                     counts=found.counts,
                                     labels=[f"I{k + 1}" for k in range(len(found))]),
                   {"intervals": found, "values": rec.acc, "time": rec.t})
        lab = run(files[0], orientations="known" if known else "unknown")
        yield lab.reduction, ({} if lab.intervals is None else {
            "intervals": lab.intervals, "values": lab.recording.values,
            "time": lab.recording.time})

    return candidates()
