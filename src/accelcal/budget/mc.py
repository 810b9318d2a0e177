"""Validation of a GUM budget by Monte Carlo propagation of its input distributions (JCGM 101).

Each input of a :class:`~accelcal.budget.gum.Budget` is sampled from its
distribution with its standard uncertainty (JCGM 101 6.4): normal,
rectangular (``a = sqrt 3 u``), triangular (``a = sqrt 6 u``), U-shaped or
arcsine (``a = sqrt 2 u``), two-point (``+-u``), and the Type A part as a scaled and shifted t
with its degrees of freedom (6.4.9: scale ``u``, ``nu`` dof; normal when
``nu`` is infinite). Correlated inputs share a Gaussian copula with the
stated ``r`` (each marginal kept); a vector input (one independent error
per position) is sampled element by element with each element's
sensitivity.

Two models: :func:`check` puts the samples through the budget's
**linearised** measurement model ``y = y0 + sum_i c_i (x_i - x_i0)`` with
its sensitivity coefficients (vectorised: it tests what the GUM assumes
about the output's distribution, a t with ``nu_eff`` degrees of freedom,
for these inputs, not the model's curvature); :func:`propagate` through the
**full** model, every trial running the method's reduction again
(:mod:`accelcal.budget.full`), in batches with JCGM 101's adaptive
procedure (7.9.4), on Dask workers where asked.

The probabilistically symmetric 95.45 % coverage interval of the Monte
Carlo (JCGM 101 7.7) is compared with the GUM's ``y +- U``: with ``u_c``
written with ``n_dig = 2`` significant digits as ``c 10^l``, the numerical
tolerance is ``delta = 10^l / 2`` (7.9.2), and the GUM result is validated
when both ``d_low = |y - U - y_low|`` and ``d_high = |y + U - y_high|`` are
at most ``delta`` (8.2).

References
----------
.. [JCGM101] JCGM 101:2008, Evaluation of measurement data - Supplement 1 to
   the GUM - Propagation of distributions using a Monte Carlo method,
   secs. 6.4, 7.2, 7.7, 7.9, 8.
"""

import math
from dataclasses import dataclass

from accelcal.budget.gum import COVERAGE

TRIALS = 1_000_000
"""Default number of trials (JCGM 101 7.2.2: 10^6 for a 95 % interval)."""

N_DIG = 2
"""Significant digits of ``u_c`` that set the numerical tolerance (JCGM 101 7.9.2)."""


@dataclass(frozen=True)
class Check:
    """The Monte Carlo validation of one budget (JCGM 101 sec. 8).

    ``model``: ``"linearised"`` (:func:`check`) or ``"reduction"``
    (:func:`propagate`). ``s_low``, ``s_high``: the numerical standard
    deviations of the Monte Carlo endpoints (of their average over the
    batches, JCGM 101 7.9.4 g); ``stabilised``: whether twice the numerical
    standard deviations of the mean, standard deviation and endpoints are
    within the tolerance of the Monte Carlo's standard uncertainty (7.9.4
    i); None in the linearised model (not estimated).
    ``failed``: trials whose reduction failed (left out).
    """

    trials: int
    seed: int
    model: str
    gum_low: float
    gum_high: float
    mc_low: float
    mc_high: float
    mc_mean: float
    mc_std: float
    delta: float
    d_low: float
    d_high: float
    validated: bool
    coverage: float = COVERAGE
    s_low: float | None = None
    s_high: float | None = None
    stabilised: bool | None = None
    failed: int = 0

    def as_dict(self) -> dict:
        """JSON-ready fields (``s_low``, ``s_high``, ``stabilised`` null when not estimated)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def tolerance(u_c: float, digits: int = N_DIG) -> float:
    """``delta = 10^l / 2``, ``u_c = c 10^l`` with ``c`` of ``digits`` digits (JCGM 101 7.9.2)."""
    if not (u_c > 0 and math.isfinite(u_c)):
        return 0.0
    exponent = math.floor(math.log10(u_c)) - (digits - 1)
    return 0.5 * 10.0**exponent


def sample(distribution: str, u: float, dof: float, size: int, rng, *, normal=None):
    """Draws of a zero-mean input of standard uncertainty ``u`` (JCGM 101 6.4).

    ``normal`` (standard normal draws) couples correlated inputs: each
    marginal is then its probability transform.
    """
    import numpy as np
    from scipy import stats

    if normal is None and distribution in ("normal", "student-t"):
        if distribution == "student-t" and math.isfinite(dof):
            return u * rng.standard_t(dof, size)  # JCGM 101 6.4.9.7: scale u, nu dof
        return u * rng.standard_normal(size)
    uniform = stats.norm.cdf(normal) if normal is not None else rng.random(size)
    if distribution == "rectangular":
        return u * math.sqrt(3.0) * (2.0 * uniform - 1.0)
    if distribution == "triangular":
        a = u * math.sqrt(6.0)
        return np.where(uniform < 0.5, -a + a * np.sqrt(2.0 * uniform),
                        a - a * np.sqrt(2.0 * (1.0 - uniform)))
    if distribution == "u-shaped":
        return -u * math.sqrt(2.0) * np.cos(np.pi * uniform)
    if distribution == "two-point":
        return np.where(uniform < 0.5, -u, u)
    if distribution == "student-t" and math.isfinite(dof):
        return u * stats.t.ppf(uniform, dof)  # JCGM 101 6.4.9.7: scale u, nu dof
    return u * (normal if normal is not None else stats.norm.ppf(uniform))


def check(budget, *, trials: int = TRIALS, seed: int = 1, correlation=None) -> Check:
    """Validate ``budget`` against a Monte Carlo propagation of its inputs.

    Parameters
    ----------
    budget : accelcal.budget.gum.Budget
    trials : int
    seed : int
    correlation : dict, optional
        ``{(q_a, q_b): r}`` as given to :func:`~accelcal.budget.gum.combine`
        (the lab's correlations); needed when ``budget.correlated``.

    Returns
    -------
    Check
    """
    import numpy as np

    rng = np.random.default_rng(seed)
    rows = [r for r in budget.rows if r.u > 0 and r.sensitivity != 0]
    names = [r.quantity for r in rows]
    pairs = {}
    for (a, b), r in (correlation or {}).items():
        if a in names and b in names:
            pairs[(a, b)] = pairs[(b, a)] = r
    normals = {}
    if pairs:
        coupled = sorted({q for p in pairs for q in p}, key=names.index)
        cov = np.eye(len(coupled))
        for i, a in enumerate(coupled):
            for j, b in enumerate(coupled):
                if i != j:
                    cov[i, j] = pairs.get((a, b), 0.0)
        z = rng.multivariate_normal(np.zeros(len(coupled)), cov, size=trials, method="eigh")
        normals = {q: z[:, i] for i, q in enumerate(coupled)}
    y = np.full(trials, float(budget.estimate))
    for row in rows:
        if row.components and row.quantity not in normals:  # independent per element
            for c in row.components:
                y += c * sample(row.distribution, row.u, row.dof, trials, rng)
            continue
        y += row.sensitivity * sample(row.distribution, row.u, row.dof, trials, rng,
                                      normal=normals.get(row.quantity))
    p = COVERAGE
    low, high = np.quantile(y, [(1.0 - p) / 2.0, (1.0 + p) / 2.0])
    delta = tolerance(budget.u_c)
    gum_low, gum_high = budget.estimate - budget.U, budget.estimate + budget.U
    d_low, d_high = abs(gum_low - low), abs(gum_high - high)
    return Check(int(trials), int(seed), "linearised", gum_low, gum_high, float(low),
                 float(high), float(y.mean()), float(y.std(ddof=1)), delta, float(d_low),
                 float(d_high),
                 bool(d_low <= delta and d_high <= delta))


BATCH = 10_000
"""Trials per batch of the adaptive procedure (JCGM 101 7.9.4 b: ``M = max(100 / (1 - p),
10^4)``)."""

MAX_ADAPTIVE = 50_000
"""Most trials of the full model when no count is given and each trial runs the reduction
again (five batches; :data:`TRIALS` when none does: the trials are then vectorised)."""

MAX_FULL_TRIALS = 1_000_000
"""Most trials of the full model (each a reduction; all are kept for the intervals)."""

BLOCK = 64
"""Trials per seed block of the full model when each runs the reduction again (with the
seed, what the draws depend on; vectorised trials: the engine's 4096)."""

MAX_SECONDS = 600.0
"""Longest full-model run accepted without ``force``, s (estimated from a few reductions)."""

PROBE = 8
"""Trials timed to estimate a full-model run."""

REFERENCE = 2_000_000
"""Trials of the linearised model that the full model's estimates are referred to (at
most; twenty per full-model trial, at least :data:`REFERENCE_BATCH`, for a count given):
its endpoints' numerical standard deviation is then 0.2 % of ``u``, within any tolerance
of two significant digits."""

REFERENCE_BATCH = 100_000
"""Trials per batch of the linearised reference."""


def propagate(study, budgets, *, trials: int | None = None, seed: int = 1,
              workers: int | None = None, scheduler: str | None = None,
              timeout: float = 10.0, force: bool = False, progress=None) -> list[Check]:
    """Validate one reduction's budgets against the Monte Carlo of the full model.

    Parameters
    ----------
    study : accelcal.budget.full.Study
        The reduction's full measurement model (:func:`accelcal.budget.full.model_of`).
    budgets : list of Budget
        Its budgets, one per output of ``study``.
    trials : int, optional
        Trials in batches of about :data:`BATCH` (at least two batches).
        None: the adaptive procedure (JCGM 101 7.9.4): batches of
        :data:`BATCH` until every budget is stabilised, at most
        :data:`MAX_ADAPTIVE` trials (:data:`TRIALS` when no trial runs the
        reduction again).
    seed : int
        Batch ``h`` draws from :func:`accelcal.montecarlo.run` seeded with
        ``SeedSequence(seed, spawn_key=(h,))``: the result depends on
        ``seed`` and ``trials`` only, not on ``workers`` or ``scheduler``.
    workers, scheduler, timeout :
        As :func:`accelcal.montecarlo.run` takes them; a local cluster is
        started once for all batches.
    force : bool
        Run a study estimated (from :data:`PROBE` reductions, timed) to take
        longer than :data:`MAX_SECONDS` locally (the adaptive procedure: its
        first two batches, the fewest it runs); refused otherwise.
    progress : callable, optional
        ``progress(done, total)`` over all batches.

    Returns
    -------
    list of Check
        One per budget, ``model="reduction"``. The mean, standard deviation
        and endpoints use the linearised model as a control variate: the
        full model's on the trials, less the linearised model's on the same
        draws, plus the linearised model's from :data:`REFERENCE`
        vectorised trials (a variance reduction: the two move together
        where the model is nearly linear; the estimate is the full model's
        either way).

    References
    ----------
    .. [Glasserman2004] Glasserman P., Monte Carlo Methods in Financial
       Engineering, Springer 2004, secs. 4.1 (control variates) and 9.1
       (quantile estimation).
    """
    import contextlib

    import numpy as np

    from accelcal import montecarlo
    from accelcal.errors import AccelcalError

    montecarlo.check_parallel(workers, scheduler, timeout)
    if trials is not None and not 2 <= trials <= MAX_FULL_TRIALS:
        raise AccelcalError(f"{trials} trials of the full model: give 2 to "
                            f"{MAX_FULL_TRIALS:,} (each trial is a reduction)",
                            parameter="trials")
    sizes = _batches(trials, MAX_ADAPTIVE if study.reruns else TRIALS)
    planned = sum(sizes)
    if not force and scheduler is None and study.reruns:  # the adaptive: its first two batches
        _bound(study, planned if trials is not None else sum(sizes[:2]), workers)
    names = tuple(f"{b.serial} {b.coefficient}" for b in budgets)
    ref, s_ref = _reference(study, seed, REFERENCE if trials is None else
                            min(REFERENCE, max(REFERENCE_BATCH, 20 * trials)))
    diffs, pairs, done = [], [], 0
    with contextlib.ExitStack() as stack:
        address = scheduler
        if workers is not None:
            from accelcal.parallel import local_cluster

            address = stack.enter_context(local_cluster(workers)).scheduler_address
        for h, size in enumerate(sizes):
            step = None if progress is None else (
                lambda d, _t, before=done: progress(before + d, planned))
            result = montecarlo.run(study, size, names=names + names, seed=_batch_seed(seed, h),
                                    block_size=BLOCK if study.reruns else
                                    montecarlo.DEFAULT_BLOCK_SIZE, keep_samples=True,
                                    max_kept=size, covariance=False, scheduler=address,
                                    timeout=timeout, progress=step)
            pairs.append(result.samples)
            diffs.append(_difference(result.samples))
            done += size
            if trials is None and h >= 1 and all(_stabilised(np.array(diffs), ref, s_ref)):
                break
    y = np.concatenate(pairs)
    diffs = np.array(diffs)  # (batches, 4, outputs): full less linearised
    cv = _difference(y) + ref  # mean, std, low, high: the control-variate estimates
    s = np.sqrt(diffs.var(axis=0, ddof=1) / len(diffs) + s_ref**2)  # two batches or more
    steady = _stabilised(diffs, ref, s_ref)
    out = []
    for j, b in enumerate(budgets):
        mean, std, low, high = (float(v) for v in cv[:, j])
        failed = int(np.count_nonzero(~np.isfinite(y[:, j])))
        delta = tolerance(b.u_c)
        gum_low, gum_high = b.estimate - b.U, b.estimate + b.U
        d_low, d_high = abs(gum_low - low), abs(gum_high - high)
        out.append(Check(len(y), int(seed), "reduction", gum_low, gum_high, low, high, mean,
                         std, delta, d_low, d_high, bool(d_low <= delta and d_high <= delta),
                         s_low=float(s[2, j]), s_high=float(s[3, j]),
                         stabilised=bool(steady[j]), failed=failed))
    return out


def _reference(study, seed: int, trials: int):
    """The linearised model's mean, std and endpoints from ``trials`` vectorised trials.

    Returns the batches' average ``(4, outputs)`` and its numerical standard
    deviation.
    """
    import dataclasses

    import numpy as np

    from accelcal.montecarlo import block_generator

    linear = dataclasses.replace(study, part="linear")
    stats = np.array([_statistics(linear(block_generator(_batch_seed(seed, r, stream=1), 0),
                                         REFERENCE_BATCH))
                      for r in range(max(2, trials // REFERENCE_BATCH))])
    return stats.mean(axis=0), stats.std(axis=0, ddof=1) / math.sqrt(len(stats))


def _difference(pairs):
    """Full less linearised mean, std and endpoints of paired trials ``(n, 2 outputs)``."""
    import numpy as np

    p = pairs.shape[1] // 2
    full, linear = pairs[:, :p], pairs[:, p:].copy()
    linear[~np.isfinite(full)] = np.nan  # a failed trial leaves both out
    return _statistics(full) - _statistics(linear)


def _batches(trials: int | None, cap: int) -> list[int]:
    """Batch sizes: ``cap / BATCH`` of :data:`BATCH`, or ``trials`` in about equal parts."""
    if trials is None:
        return [BATCH] * (cap // BATCH)
    h = max(2, round(trials / BATCH))
    return [trials // h + (1 if i < trials % h else 0) for i in range(h)]


def _batch_seed(seed: int, batch: int, *, stream: int = 0) -> int:
    """The seed of a batch: of the full model (``stream`` 0) or the linearised reference (1)."""
    import numpy as np

    key = (batch,) if stream == 0 else (stream, batch)
    return int(np.random.SeedSequence(seed, spawn_key=key).generate_state(1, np.uint64)[0])


def _statistics(samples):
    """Each output's mean, standard deviation and 95.45 % endpoints: shape (4, outputs)."""
    import warnings

    import numpy as np

    q = [(1.0 - COVERAGE) / 2.0, (1.0 + COVERAGE) / 2.0]
    if np.isfinite(samples).all():
        return np.array([samples.mean(axis=0), samples.std(axis=0, ddof=1),
                         *np.quantile(samples, q, axis=0)])
    with warnings.catch_warnings():  # an output whose every trial failed: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        low, high = np.nanquantile(samples, [(1.0 - COVERAGE) / 2.0, (1.0 + COVERAGE) / 2.0],
                                   axis=0)
        return np.array([np.nanmean(samples, axis=0), np.nanstd(samples, axis=0, ddof=1),
                         low, high])


def _stabilised(diffs, ref, s_ref):
    """Per output: ``2 s <= delta`` for the mean, std and endpoints (JCGM 101 7.9.4 g-i).

    ``diffs``: (batches, 4, outputs), the full model less the linearised;
    ``ref``, ``s_ref``: the linearised reference and its numerical standard
    deviation; ``delta`` the numerical tolerance of the Monte Carlo's
    standard uncertainty.
    """
    import numpy as np

    s = np.sqrt(diffs.var(axis=0, ddof=1) / len(diffs) + s_ref**2)
    delta = np.array([tolerance(u) for u in diffs[:, 1, :].mean(axis=0) + ref[1]])
    return [bool(np.all(2.0 * s[:, j] <= delta[j])) for j in range(s.shape[1])]


def _bound(study, planned: int, workers: int | None) -> None:
    """Refuse a run estimated to take longer than :data:`MAX_SECONDS` (from :data:`PROBE`)."""
    import time

    import numpy as np

    from accelcal.errors import AccelcalError

    start = time.monotonic()
    study(np.random.default_rng(0), PROBE)
    seconds = (time.monotonic() - start) / PROBE * planned / (workers or 1)
    if seconds > MAX_SECONDS:
        raise AccelcalError(
            f"{planned:,} trials of the full model (each a reduction) would take about "
            f"{seconds:,.0f} s (from {PROBE}, timed); the bound is {MAX_SECONDS:g} s: give "
            "fewer trials or more workers, or --force (force=True) to run it anyway",
            parameter="trials")
