"""Monte Carlo study of the indexing-head reductions: actual error versus formal SD.

For a given truth (sensor models, mounts, misalignments), positions, head
angle-error profile, first harmonic and noise, many trials are simulated
and reduced by each method; for every method, sensor and coefficient the
study reports the RMS of the actual error and the mean of the formal
standard deviation the method itself reports. Where the two agree the
method's uncertainty is honest; where the RMS error is larger the formal
SD understates it.

Methods: ``single``, ``four_unknown_h1``, ``four_known_h1``,
``joint_unknown_h1``, ``joint_known_h1``. "Known" means the method is
given the realised first harmonic of the head error (plus a measurement
error of standard deviation ``h1_sd``, which it includes in its
covariance); "unknown" means it takes the first harmonic as zero.

The actual error is measured against the identifiable truth: K_F, K_I,
K_IO, K_II as simulated and ``K_O* = K_O + K_I (eta + d0)`` with d0 the
realised mean head error (no method can separate it, [DOMAIN] step 6).

The study runs on :func:`accelcal.montecarlo.run`:
:class:`~accelcal.methods.dividing_head.study_kernel.HeadStudy`
turns ``n`` trials drawn from a seed block's generator into one row of
outputs per trial (every error, plus the formal-SD factors), and the engine
keeps streaming means and RMS values. Results depend only on the rig, the
methods, ``h1_sd``, the seed and the block size: they are bit-identical
for any ``chunk``, in-process or on any number of Dask workers.

Vectorised: the designs are fixed, so every reduction is a precomputed
linear operator (after each sensor's normalisation by its own fitted scale
factor) applied to :data:`~accelcal.methods.dividing_head.study_kernel.CHUNK` trials
at once by matrix products, trials on the contiguous axis (the random numbers
are drawn :data:`~accelcal.methods.dividing_head.study_kernel.SUB_BLOCK` trials
at a time), and each chunk's outputs stream to the engine while in cache.
:func:`~accelcal.methods.dividing_head.exact.exact_study` gives what the study
converges to, without sampling. The outputs enter only as their variation
about the noise-free outputs at zero head error (a Taylor series in the
head error, :meth:`SensorBank.variation`), so nothing is rounded at the
outputs' magnitude; the constant part is fitted once in extended
precision. The single fit gives each sensor's estimates and orthonormal
residual coordinates (``n - 5`` numbers); ``four`` and ``joint`` differ from
it only by removing a head-error estimate whose effect lies in one small
subspace of those coordinates, so both act on a few projections of them.
There is no per-trial Python loop.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, section 3, Tables 1-2.
.. [DOMAIN] accelcal domain notes, section 4 (checks: formal SDs against
   Monte Carlo RMS errors).
"""

import math
from dataclasses import dataclass

import numpy as np

from accelcal import montecarlo, work
from accelcal.errors import AccelcalError
from accelcal.io.formats.dividing_head import MAX_ANGLE_ERROR_RAD
from accelcal.methods.dividing_head.four import FourOperator
from accelcal.methods.dividing_head.joint import JointOperator
from accelcal.methods.dividing_head.study_kernel import HeadStudy
from accelcal.methods.dividing_head.theory import COEFFICIENTS
from accelcal.rigs.dividing_head import DividingHeadRig
from accelcal.validation import shown

STUDY_METHODS = ("single", "four_unknown_h1", "four_known_h1", "joint_unknown_h1",
                 "joint_known_h1")

STUDY_BLOCK = 2**15
"""Default trials per seed block (part of a study's identity, with the seed)."""


@dataclass(frozen=True)
class StudyResult:
    """Monte Carlo study result.

    Attributes
    ----------
    methods : tuple of str
        Method names (first axis).
    rms_error : numpy.ndarray
        RMS actual error, shape ``(methods, K, 5)``, output unit.
    mean_formal_sd : numpy.ndarray
        Mean formal SD, same shape.
    trials : int
        Number of trials.
    output_unit : str
        Unit of the outputs (coefficient units follow from it).
    notes : tuple of str
        Methods left out because the rig does not allow them, and why.
    """

    methods: tuple
    rms_error: np.ndarray
    mean_formal_sd: np.ndarray
    trials: int
    output_unit: str = "V"
    notes: tuple = ()

    def rows(self, per_sensor: bool = False) -> list[dict]:
        """Rows ``{method, coefficient, rms_error, mean_formal_sd}``.

        Averaged over sensors (RMS of the RMS errors, mean of the formal SDs)
        unless ``per_sensor``, which adds a ``sensor`` key.
        """
        rows = []
        for m, name in enumerate(self.methods):
            if per_sensor:
                for k in range(self.rms_error.shape[1]):
                    rows.extend(
                        {"method": name, "sensor": f"U{k + 1}", "coefficient": c,
                         "rms_error": float(self.rms_error[m, k, i]),
                         "mean_formal_sd": float(self.mean_formal_sd[m, k, i])}
                        for i, c in enumerate(COEFFICIENTS)
                    )
                continue
            rms = np.sqrt(np.mean(self.rms_error[m] ** 2, axis=0))
            sd = np.mean(self.mean_formal_sd[m], axis=0)
            rows.extend(
                {"method": name, "coefficient": c, "rms_error": float(rms[i]),
                 "mean_formal_sd": float(sd[i])}
                for i, c in enumerate(COEFFICIENTS)
            )
        return rows


def run_study(
    rig: DividingHeadRig,
    trials: int,
    seed=0,
    *,
    h1_sd: float = 0.0,
    chunk: int | None = None,
    methods=None,
    block_size: int = STUDY_BLOCK,
    workers: int | None = None,
    scheduler: str | None = None,
    progress=None,
    timeout: float = montecarlo.SCHEDULER_TIMEOUT_S,
    force: bool = False,
) -> StudyResult:
    """Run the Monte Carlo study on :func:`accelcal.montecarlo.run`.

    Parameters
    ----------
    rig : DividingHeadRig
        Truth, positions, mounts, head error profile, first harmonic, noise.
        ``four`` methods need uniform positions (n >= 12) and balanced mounts.
    trials : int
        Number of trials (2 ... :data:`accelcal.montecarlo.MAX_TRIALS`).
    seed : int
        Root seed (>= 0).
    h1_sd : float
        Standard deviation of the first-harmonic measurement given to the
        ``known_h1`` methods, rad (their covariance includes it); at most
        1 deg.
    chunk : int, optional
        Trials per task, rounded up to whole seed blocks (default one
        block): scheduling and progress granularity. Does not change the
        result.
    methods : sequence of str, optional
        Subset of :data:`STUDY_METHODS`; by default every method the rig
        allows (``four`` needs uniform positions and balanced mounts,
        ``joint`` an identifiable design).
    block_size : int
        Trials per seed block. Part of the study's identity (with the seed):
        changing it changes which random numbers each trial gets.
    workers : int, optional
        Run on a Dask local cluster of this many worker processes (at most
        :func:`accelcal.montecarlo.max_workers`).
    scheduler : str, optional
        Run on the Dask scheduler at this address (``tcp://host:8786``).
    progress : callable, optional
        ``progress(done, total)`` called as trials complete.
    timeout : float
        Seconds to wait for ``scheduler`` to answer (positive, at most one day).
    force : bool
        Run a study estimated (from its first task, timed) to take longer
        than :data:`accelcal.work.MAX_SECONDS` locally; refused otherwise.

    Returns
    -------
    StudyResult
        Bit-identical for any ``chunk``, ``workers`` or ``scheduler``.

    References
    ----------
    .. [1] [DOMAIN] section 4: formal SDs against Monte Carlo RMS errors.
    """
    if isinstance(trials, bool) or not isinstance(trials, (int, np.integer)) or trials < 2:
        raise AccelcalError(f"a study needs at least 2 trials, got {shown(trials)}",
                            parameter="trials")
    notes: tuple[str, ...] = ()
    if methods is None:
        methods, notes = _applicable(rig)
    methods = tuple(methods)
    bad = [m for m in methods if m not in STUDY_METHODS]
    if bad:
        raise AccelcalError(
            f"unknown study method(s) {bad}; choose from {', '.join(STUDY_METHODS)}",
            parameter="methods",
        )
    montecarlo.check_trials(trials)
    if not 0 <= _real(h1_sd) <= MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(
            f"must be a standard deviation >= 0 rad and at most 1 deg "
            f"({MAX_ANGLE_ERROR_RAD:.4g} rad; a first-harmonic measurement's is a fraction of "
            f"an arcsec), got {shown(h1_sd)}", parameter="h1_sd")
    if chunk is not None and not (_real(chunk) >= 1 and int(chunk) == chunk):
        raise AccelcalError(f"must be a positive number of trials, got {shown(chunk)}",
                            parameter="chunk")
    montecarlo.check_parallel(workers, scheduler, timeout)
    study = HeadStudy(rig, methods, float(h1_sd))
    blocks_per_task = 1 if chunk is None else max(1, -(-int(chunk) // block_size))
    # Only means and RMS are needed: the engine keeps variances, not the p x p
    # covariance, and runs each task with one BLAS thread (the products are small).
    result = montecarlo.run(
        study, int(trials), names=study.names, seed=seed, block_size=block_size,
        blocks_per_task=blocks_per_task, covariance=False,
        workers=workers, scheduler=scheduler, progress=progress, timeout=timeout,
        max_seconds=None if force else work.MAX_SECONDS,
    )
    rms_error, mean_sd = study.summarise(result.rms, result.mean)
    unit = rig.models[0].output_unit
    return StudyResult(methods, rms_error, mean_sd, int(trials), unit, notes)


def _real(value) -> float:
    """``value`` as a finite float, else NaN, which fails every range check.

    NaN for a bool, a non-number, an infinity or an integer beyond the float range.
    """
    if isinstance(value, bool):
        return math.nan
    try:
        value = float(value)
    except (TypeError, ValueError, OverflowError):
        return math.nan
    return value if math.isfinite(value) else math.nan


def _applicable(rig) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The study methods the rig's positions and mounts allow, and why others are left out."""
    methods, notes = ["single"], []
    for prefix, build in (("four", FourOperator.build), ("joint", JointOperator.build)):
        try:
            build(rig.positions, rig.mounts)
        except AccelcalError as exc:
            notes.append(f"{prefix} methods left out: {exc}")
            continue
        methods += [f"{prefix}_unknown_h1", f"{prefix}_known_h1"]
    return tuple(methods), tuple(notes)
