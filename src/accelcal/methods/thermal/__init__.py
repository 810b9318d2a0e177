"""Temperature: thermal-chamber tests, temperature coefficients, hysteresis, warm-up (issue 15).

A multipoint tumble at each temperature plateau of a chamber programme,
after a soak, gives the model's coefficients per plateau; polynomials in
the sensor temperature about a reference T0 then give the temperature
coefficients, the hysteresis between heating and cooling, the warm-up
after turn-on and the residual after compensation. The package:

:mod:`~accelcal.methods.thermal.settle`
    :func:`settling`: when a plateau is usable.
:mod:`~accelcal.methods.thermal.plateaus`
    :func:`reduce_plateaus`: settling checks and one tumble reduction per
    plateau (:func:`accelcal.methods.tumble.reduce_tumble`).
:mod:`~accelcal.methods.thermal.poly`
    :func:`fit_polynomial`: weighted least squares with the order chosen by
    an F-test.
:mod:`~accelcal.methods.thermal.warmup`
    :func:`fit_warmup`: the warm-up time constant and settled output.
:mod:`~accelcal.methods.thermal.reduce`
    :func:`reduce_thermal`: the :class:`~accelcal.results.Reduction`.
:mod:`~accelcal.methods.thermal.compensation`
    :class:`Compensation`: the compensation model (JSON) and its application
    to a recording with a temperature column, streamed.
:mod:`~accelcal.methods.thermal.figures`
    :func:`figures`: coefficients against temperature, hysteresis loop,
    residual after compensation, warm-up.

The rig simulator is :mod:`accelcal.rigs.thermal`, the record format
:mod:`accelcal.io.formats.thermal`. The verbs every method package has:
:func:`simulate` (the rig) and :func:`reduce` (a record, or its file, to a
Reduction: what ``accelcal thermal reduce`` does); ``reduce_thermal`` stays
as it was.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, IEEE Specification Format Guide and Test
   Procedure for Linear Single-Axis, Nongyroscopic Accelerometers (thermal
   sensitivity, thermal tests).
.. [DOMAIN] accelcal domain notes, section 8.
"""

from accelcal.methods import ReportText
from accelcal.methods.thermal.compensation import Compensation, compensate_stream
from accelcal.methods.thermal.figures import figures
from accelcal.methods.thermal.plateaus import Plateau, reduce_plateaus
from accelcal.methods.thermal.poly import ALPHA, PolyFit, fit_polynomial
from accelcal.methods.thermal.reduce import FAMILY, METHOD, ORDERS, default_terms, reduce_thermal
from accelcal.methods.thermal.settle import Settling, settling
from accelcal.methods.thermal.warmup import WarmupFit, fit_warmup

__all__ = [
    "ALPHA", "ERRATA", "FAMILY", "METHOD", "ORDERS", "Compensation", "Plateau", "PolyFit",
    "Settling", "WarmupFit", "compensate_stream", "default_terms", "figures", "fit_polynomial",
    "fit_warmup", "reduce", "reduce_plateaus", "reduce_thermal", "report_text", "settling",
    "simulate",
]

ERRATA = (
    ("K1's temperature coefficients are relative (K1(T) = K1 (1 + sum c1_k dT^k), 1e-6/degC = "
     "1 ppm/degC), as DOMAIN section 8 writes them; the others are additive, in the term's "
     "unit per degC^k."),
    ("The interval of a coefficient whose polynomial order was chosen by the F-test is "
     "conditional on that choice; the coverage is measured both with a fixed order and with "
     "the order chosen (docs/thermal.md)."),
)
"""Precisions of DOMAIN section 8 that a report shows (docs/thermal.md, docs/errata.md)."""


def report_text(reduction) -> ReportText:
    """The report's title and summary of a thermal reduction."""
    prov = reduction.provenance
    orders = ", ".join(f"{b} {m}" for b, m in prov.get("orders", {}).items())
    return ReportText(
        title="Thermal-chamber test (temperature coefficients)",
        summary=(f"Multipoint tumble about {prov.get('rotation_axis', '')} at "
                 f"{prov.get('plateaus', 0)} temperature plateaus after a soak "
                 f"({prov.get('plateau_method', '')} per plateau); polynomials in the sensor "
                 f"temperature about T0 = {prov.get('reference_degC', float('nan')):g} degC by "
                 f"weighted least squares (orders {orders}), heating-minus-cooling hysteresis, "
                 "warm-up after turn-on and the residual after compensation."),
        sensor_summary="Model K0(T) = K0 + Σ K0_Tk (T − T0)^k, K1(T) = K1 (1 + Σ K1_Tk "
                       "(T − T0)^k), likewise K2 and the misalignment.",
        paper="IEEE1293",
    )


def simulate(model, programme=None, *, seed=None, **settings):
    """A simulated thermal-chamber test: the rig's :func:`accelcal.rigs.thermal.simulate`.

    ``settings``: ``tau``, ``rotation_axis``, ``noise``, ``temperature_noise``,
    the warm-up, hysteresis and rate-sensitivity terms; ``seed`` an int,
    SeedSequence or Generator.
    """
    from accelcal.rigs.thermal import simulate as rig_simulate

    return rig_simulate(model, programme, seed=seed, **settings)


def reduce(records, *, gaps: str = "refuse", max_fill: int = 5, **options):
    """Reduce a thermal record (or its file), as ``accelcal thermal reduce`` does.

    :func:`reduce_thermal` of the record; ``options`` are its own (``order``,
    ``reference``, ``terms``, ``alpha``, ``window``, ``rate_limit``,
    ``tolerance``); ``gaps``, ``max_fill``: a file's gaps inside a plateau
    (:func:`accelcal.io.formats.thermal.read`), what was done in the
    reduction's provenance (``repairs``) and notes.
    """
    from os import PathLike

    from accelcal.io.recordings.repairs import with_repairs

    record = records
    if isinstance(records, str | PathLike):
        from accelcal.io.formats import thermal as thermal_format

        record = thermal_format.read(records, gaps=gaps, max_fill=max_fill)
    return with_repairs(reduce_thermal(record, **options), record.metadata.get("repairs"))


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.io.formats import thermal

    return [(reduce_thermal(thermal.read(files[0])), {})]
