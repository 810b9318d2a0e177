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
the simulator is :mod:`accelcal.rigs.vibrafuge`. The verbs every method
package has: :func:`simulate` (the rig), :func:`reduce` (vibrafuge runs, or
their files, to the identification: what ``accelcal vre fit`` does) and
:func:`uncertainty` (Monte Carlo); :func:`identify` (measured VRE) and
:func:`vre_uncertainty` stay as they were.

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (1)-(25), Table 1, Figs. 2-4.
"""

from accelcal.io.formats.vibrafuge import VibrafugeRun
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
from accelcal.methods.vre.measure import (
    HARMONICS,
    VreMeasurement,
    measure_runs,
    reduce_run,
    sampled_columns,
)

__all__ = [
    "ERRATA", "FAMILY", "HARMONICS", "METHOD", "PAPER_TERMS", "VRE_TERMS", "VreMeasurement",
    "VreSampler", "VreTable", "along_ia", "asymmetry_vre", "even_order_vre", "figures",
    "identify", "measure_runs", "reduce", "reduce_run", "relative_error", "report_text",
    "sampled_columns", "sgn_shape", "simulate", "table_figures", "uncertainty", "vector_vre",
    "vre_columns", "vre_table", "vre_uncertainty",
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


def simulate(model, overload, amplitude, *, seed=None, **settings):
    """Simulate vibrafuge test points: the rig's :func:`accelcal.rigs.vibrafuge.simulate`.

    ``settings``: ``frequency``, ``sample_rate``, ``duration`` (required),
    ``direction``, ``phase``, ``noise``, ``quantum``, ``sampling``,
    ``centrifuge``; ``seed`` an int, SeedSequence or Generator.
    """
    from accelcal.rigs.vibrafuge import simulate as rig_simulate

    return rig_simulate(model, overload, amplitude, seed=seed, **settings)


def reduce(records, *, terms=PAPER_TERMS, fixed=None):
    """Identify the VRE coefficients from vibrafuge runs, as ``accelcal vre fit`` does.

    Every run (a :class:`~accelcal.io.formats.vibrafuge.VibrafugeRun` or its
    file) is reduced to measured VRE (:func:`measure_runs`); the points
    together go to :func:`identify` with their directions, uncertainties and
    design columns [Guan2021]_.

    Parameters
    ----------
    records : path-like or VibrafugeRun, or a sequence of them
    terms : sequence of str
        Coefficients to fit (default the paper's K2, K3, K0_asym, K1_asym).
    fixed : mapping, optional
        Coefficients held at known values.

    Returns
    -------
    accelcal.results.Reduction
        Method ``vre/identify``.
    """
    from os import PathLike

    runs = [records] if isinstance(records, str | PathLike | VibrafugeRun) else list(records)
    m = measure_runs(runs)
    files = [str(r) for r in runs if isinstance(r, str | PathLike)]
    return identify(m["overload"], m["amplitude"], m["vre"], m["uncertainty"],
                    direction=m["direction"], terms=terms, fixed=fixed or {},
                    provenance={"files": files}, assumptions=m["assumptions"],
                    columns=m["columns"])


def uncertainty(reduction, *, trials: int, seed: int, **options):
    """Monte Carlo (GUM-S1) uncertainty of an identification: :func:`vre_uncertainty`."""
    return vre_uncertainty(reduction, trials=trials, seed=seed, **options)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.io.formats.vibrafuge import read_vibrafuge
    from accelcal.methods.vre import PAPER_TERMS, identify, reduce_run

    meas = reduce_run(read_vibrafuge(files[0]))
    return [(identify(meas.overload, meas.amplitude, meas.vre, meas.uncertainty,
                      direction=meas.direction, terms=PAPER_TERMS,
                      assumptions=meas.assumptions()), {})]
