"""Indexing (dividing) head: reductions of accelerometers turned in gravity (Dong2014, corrected).

Data: nominal head angles, sensor outputs and mount phases
(:class:`HeadData`, e.g. :meth:`HeadData.from_record` of a
``dividing-head`` record file). Every reduction returns a
:class:`~accelcal.results.Reduction` (family ``dividing-head``; fields in
:mod:`accelcal.methods.dividing_head.result`):

* ``single`` (:func:`single`): each sensor alone; the head error biases
  every coefficient.
* ``four`` (:func:`four`): Dong2014's separation of the head error, as
  corrected in [DOMAIN] section 4 (steps 0-7).
* ``joint`` (:func:`joint`): one least-squares problem for all sensors and
  all per-position head errors with the gauge fixed; optional
  autocollimator readings and Gauss-Newton iteration on the exact model.
* ``tumble`` (:func:`tumble`): the IEEE 1293 multipoint reduction of each
  sensor, mapped to Dong2014's coefficients.

:func:`reduce` runs any of them by name (the one place that checks which
options a method takes), on data or on a record file as ``accelcal
dividing-head reduce`` does. The verbs every method package has:
:func:`simulate` (the rig), :func:`reduce` and :func:`uncertainty` (Monte
Carlo, :func:`head_uncertainty`). Monte Carlo: :func:`head_uncertainty` (GUM-S1
uncertainty of a reduction of measured data) and :func:`run_study` (formal
SDs against actual errors over simulated experiments). Modules: ``theory``
(basis, alias, names), ``data``, ``single``, ``four`` (with ``factors``:
the steps as O(n) factors), ``joint`` (with ``arrow``: the O(n) solver and
identifiability), ``reduce``, ``result``, ``sizes`` (memory estimates,
dense limits), ``mc``, ``study`` (``study_kernel``, ``study_bank``),
``figures``, ``report``. Reductions of measured data take time and memory
linear in the number of readings.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (5)-(31).
.. [DOMAIN] accelcal domain notes, section 4 (corrected expansions and
   reduction steps 0-7; joint least squares).
"""

from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.exact import exact_study
from accelcal.methods.dividing_head.factors import FourFactors
from accelcal.methods.dividing_head.figures import figures
from accelcal.methods.dividing_head.four import (
    FOUR_COVARIANCES,
    FourOperator,
    four,
    residual_noise_variances,
)
from accelcal.methods.dividing_head.joint import (
    JointOperator,
    gauge_basis,
    identifiability,
    joint,
    joint_design,
    null_space_dim,
)
from accelcal.methods.dividing_head.mc import (
    MC_METHODS,
    HeadSampler,
    head_uncertainty,
    noise_levels,
)
from accelcal.methods.dividing_head.reduce import (
    OPTIONS,
    lab_options,
    options_from_record,
    reduce,
    tumble,
)
from accelcal.methods.dividing_head.report import ERRATA, report_text
from accelcal.methods.dividing_head.single import scale_factors, single, single_operator
from accelcal.methods.dividing_head.study import (
    STUDY_BLOCK,
    STUDY_METHODS,
    StudyResult,
    run_study,
)
from accelcal.methods.dividing_head.study_bank import SensorBank
from accelcal.methods.dividing_head.study_kernel import SUB_BLOCK, HeadStudy
from accelcal.methods.dividing_head.theory import (
    COEFFICIENTS,
    FAMILY,
    METHODS,
    coefficient_units,
    first_harmonic_alias,
    method_name,
    psi,
)

__all__ = [
    "COEFFICIENTS",
    "ERRATA",
    "FAMILY",
    "FOUR_COVARIANCES",
    "MC_METHODS",
    "METHODS",
    "OPTIONS",
    "STUDY_BLOCK",
    "STUDY_METHODS",
    "SUB_BLOCK",
    "FourFactors",
    "FourOperator",
    "HeadData",
    "HeadSampler",
    "HeadStudy",
    "JointOperator",
    "SensorBank",
    "StudyResult",
    "coefficient_units",
    "exact_study",
    "figures",
    "first_harmonic_alias",
    "four",
    "gauge_basis",
    "head_uncertainty",
    "identifiability",
    "joint",
    "joint_design",
    "lab_options",
    "method_name",
    "noise_levels",
    "null_space_dim",
    "options_from_record",
    "psi",
    "reduce",
    "report_text",
    "residual_noise_variances",
    "run_study",
    "scale_factors",
    "simulate",
    "single",
    "single_operator",
    "tumble",
    "uncertainty",
]


def simulate(rig, seed=None, *, trials=None):
    """Readings on the indexing head: the rig's :func:`accelcal.rigs.dividing_head.simulate`.

    ``seed`` an int, SeedSequence or Generator (None: noise-free).
    """
    from accelcal.rigs.dividing_head import simulate as rig_simulate

    return rig_simulate(rig, seed, trials=trials)


def uncertainty(reduction, data, *, trials: int, seed: int, **options):
    """Monte Carlo (GUM-S1) uncertainty of a reduction of ``data``: :func:`head_uncertainty`.

    ``data`` is the :class:`HeadData` reduced (or its record file).
    """
    from os import PathLike

    if isinstance(data, str | PathLike):
        from accelcal.io.formats.dividing_head import read_head_record

        data = HeadData.from_record(read_head_record(data))
    return head_uncertainty(data, reduction, trials=trials, seed=seed, **options)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    import numpy as np

    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.method_ids import route_of
    from accelcal.methods.dividing_head import HeadData, options_from_record, reduce

    route = route_of(record.method)
    rec = read_head_record(files[0])
    red = reduce(HeadData.from_record(rec), route, **options_from_record(rec, route))
    truth = None
    if rec.simulation and "angle_error_rad" in rec.simulation:
        truth = np.asarray(rec.simulation["angle_error_rad"], dtype=float)
    return [(red, {"truth": truth})]
