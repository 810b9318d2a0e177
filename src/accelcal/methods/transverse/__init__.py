"""Transverse sensitivity of an accelerometer on a shaker (GuanTang, after ISO 16063-31).

The package, along its seams:

:mod:`~accelcal.methods.transverse.theory`
    Closed forms of s_T(theta) for the linear and the inertial model, the
    axial sensitivity definitions, direction-angle checks, GuanTang Fig. 4's
    parameter set.
:mod:`~accelcal.methods.transverse.estimators`
    s_T per angle from records with a named estimator (``peak``,
    ``half-p2p``, ``fundamental``), and the simulated sweep.
:mod:`~accelcal.methods.transverse.identification`
    Beyond the paper: the cross-axis coefficients k_o, k_p, k_oo, k_pp, k_op
    from the w, 2w and DC components (:func:`identify`, a
    :class:`~accelcal.results.Reduction`; :func:`identify_arrays`, batched).
:mod:`~accelcal.methods.transverse.mc`
    Monte Carlo (GUM-S1) uncertainty of the identification.
:mod:`~accelcal.methods.transverse.figures`
    Polar plots, GuanTang Fig. 4, and a reduction's figures.

Records are :class:`accelcal.io.formats.shaker.ShakerRecords`, simulated by
:class:`accelcal.rigs.shaker.ShakerRig`. The verbs every method package
has: :func:`simulate` (the rig), :func:`reduce` (the records of one
amplitude, or their directory, to the identification: what ``accelcal
transverse fit`` does per amplitude) and :func:`uncertainty` (Monte Carlo);
:func:`identify` and :func:`transverse_uncertainty` stay as they were.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (2), (7)-(25) as reconstructed in
   docs/domain.md section 3.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration sensitivity.
"""

from accelcal.errors import AccelcalError
from accelcal.methods import ReportText
from accelcal.methods.transverse.estimators import (
    PEAK_COVERAGE,
    TransverseSweep,
    estimate_sT,
    record_phasors,
    records_axial_sensitivity,
    summarize,
    sweep,
    w_ratio,
    with_fitted_frequency,
)
from accelcal.methods.transverse.figures import figure4, figures, polar_figure, save_polar
from accelcal.methods.transverse.identification import (
    DEFAULT_FIT,
    FIT_TERMS,
    ROUTE_TEXT,
    ROUTES,
    check_route,
    identify,
    identify_arrays,
    observation_columns,
    observation_covariance,
    regressors,
)
from accelcal.methods.transverse.mc import TransverseSampler, transverse_uncertainty
from accelcal.methods.transverse.theory import (
    AXIAL_DEFINITIONS,
    ESTIMATORS,
    GUANTANG_FIG4,
    axial_sensitivity,
    check_angles,
    check_axial,
    check_estimator,
    closed_form_sT,
    cross_axis_B,
    cross_axis_C,
    figure4_linear,
    fundamental_extremes,
    linear_sT,
)

__all__ = [
    "AXIAL_DEFINITIONS", "DEFAULT_FIT", "ERRATA", "ESTIMATORS", "FIT_TERMS", "GUANTANG_FIG4",
    "PEAK_COVERAGE", "ROUTES", "ROUTE_TEXT", "TransverseSampler", "TransverseSweep",
    "axial_sensitivity", "check_angles", "check_axial", "check_estimator", "check_route",
    "closed_form_sT", "cross_axis_B", "cross_axis_C", "estimate_sT", "figure4",
    "figure4_linear", "figures", "fundamental_extremes", "identify", "identify_arrays",
    "linear_sT", "observation_columns", "observation_covariance", "polar_figure",
    "record_phasors", "records_axial_sensitivity", "reduce", "regressors", "report_text",
    "save_polar", "simulate", "summarize", "sweep", "transverse_uncertainty", "uncertainty",
    "w_ratio", "with_fitted_frequency",
]

ERRATA = (
    ("The lost equations (1), (3), (6)-(12), (14)-(24) are reconstructed and checked "
     "against time-domain simulation."),
    ("The drive law (4) cannot remove gravity on a vertical shaker; the static 1 g along "
     "the vibration axis is modelled (fundamental k_i |B + 2 G C|)."),
    ("The peak definition (21)-(22) of s_T depends on the amplitude; the coefficients are "
     "fitted to the w and 2w phasors instead, and the polar plot shows the fundamental "
     "(ISO 16063-31 practice)."),
    "alpha = atan2(s_p, s_o) replaces arctan(s_p / s_o), which loses the quadrant.",
)
"""Corrections of GuanTang that a report shows (details in docs/errata.md)."""


def report_text(reduction) -> ReportText:
    """Title and summary of a shaker identification's report section.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        An :func:`identify` result.

    Returns
    -------
    accelcal.methods.ReportText
    """
    amplitude = reduction.assumed("amplitude")
    angles = reduction.observations["angle_deg"].size
    return ReportText(
        title=f"transverse sensitivity (shaker, {amplitude:g} g)",
        summary=(f"Sinusoidal vibration of {amplitude:g} g at "
                 f"{reduction.assumed('frequency'):g} Hz along {angles} directions in the "
                 f"transverse plane; cross-axis coefficients from "
                 f"{ROUTE_TEXT[reduction.assumed('route')]} (GuanTang, identification beyond "
                 "the paper)."),
        paper="GuanTang",
    )


def simulate(sensor, theta, *, rig=None, seed=None, trials=None):
    """Shaker records of ``sensor`` at direction angles ``theta`` (rad).

    The rig's :meth:`accelcal.rigs.shaker.ShakerRig.simulate` on ``rig``
    (default ``ShakerRig()``); ``seed`` an int, SeedSequence or Generator
    (None: noise-free).
    """
    from accelcal.rigs.shaker import ShakerRig

    return (ShakerRig() if rig is None else rig).simulate(sensor, theta, seed=seed,
                                                          trials=trials)


def reduce(records, *, route: str = "2w", terms=DEFAULT_FIT, base=None, scale_factor=None,
           fit_frequency: bool = False):
    """Identify the cross-axis coefficients of one amplitude, as ``accelcal transverse fit``.

    Parameters
    ----------
    records : accelcal.io.formats.shaker.ShakerRecords or path-like
        The records of one amplitude, or a file or directory holding them
        (:func:`accelcal.io.formats.shaker.read_records`).
    route, terms, base, scale_factor
        As :func:`identify` takes them.
    fit_frequency : bool
        Fit the vibration frequency to the reference channel first
        (:func:`with_fitted_frequency`, IEEE 1057) instead of trusting the
        records' nominal one.

    Returns
    -------
    accelcal.results.Reduction
        Method ``transverse/<route>`` [GuanTang]_.

    Raises
    ------
    AccelcalError
        For a directory holding several amplitudes (reduce each).
    """
    from os import PathLike

    if isinstance(records, str | PathLike):
        from accelcal.io.formats.shaker import read_records

        found = read_records(records)
        if len(found) != 1:
            raise AccelcalError(f"{records} holds {len(found)} amplitudes; reduce the records "
                                "of each (accelcal.io.formats.shaker.read_records)",
                                parameter="records")
        records = found[0]
    if fit_frequency:
        records = with_fitted_frequency(records)
    return identify(records, route=route, terms=terms, base=base, scale_factor=scale_factor)


def uncertainty(reduction, records, *, trials: int, seed: int, **options):
    """Monte Carlo (GUM-S1) uncertainty of an identification of ``records``.

    :func:`transverse_uncertainty` (``options``: ``reference_sd``,
    ``shortest``, ``progress``).
    """
    return transverse_uncertainty(records, reduction, trials=trials, seed=seed, **options)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.io.formats.shaker import read_records, shaker_files
    from accelcal.method_ids import route_of
    from accelcal.methods.transverse import identify

    directory = files[0].parent
    names = {f.name for f in files}
    groups = shaker_files(directory)
    return [(identify(rec, route=route_of(record.method)), {})
            for rec in read_records(directory)
            if {f.name for f in groups.get(rec.amplitude, ())} == names]
