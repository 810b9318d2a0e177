"""Validation of a GUM budget by Monte Carlo propagation of its input distributions (JCGM 101).

Each input of a :class:`~accelcal.budget.gum.Budget` is sampled from its
distribution with its standard uncertainty (JCGM 101 6.4): normal,
rectangular (``a = sqrt 3 u``), triangular (``a = sqrt 6 u``), U-shaped or
arcsine (``a = sqrt 2 u``), two-point (``+-u``), and the Type A part as a scaled and shifted t
with its degrees of freedom (6.4.9: scale ``u``, ``nu`` dof; normal when
``nu`` is infinite). Correlated inputs share a Gaussian copula with the
stated ``r`` (each marginal kept); a vector input (one independent error
per position) is sampled element by element with each element's
sensitivity. The samples go through the budget's
**linearised** measurement model ``y = y0 + sum_i c_i (x_i - x_i0)`` with
the sensitivity coefficients of the budget: the check tests what the GUM
assumes about the output's distribution (a t with ``nu_eff`` degrees of
freedom) for these inputs, not the model's curvature (the models are linear
at the size of the inputs' uncertainties; the reduction itself is not run
per trial).

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
    """The Monte Carlo validation of one budget (JCGM 101 sec. 8)."""

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

    def as_dict(self) -> dict:
        """JSON-ready fields."""
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
