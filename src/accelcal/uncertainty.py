"""Monte Carlo uncertainty of a reduction of measured data (GUM Supplement 1).

A reduction turns measured data into coefficient estimates ``y_hat`` with a
formal (least-squares) covariance. Its Monte Carlo uncertainty follows
GUM-S1: every uncertain input is given a probability distribution (the
noise at the level the residuals show, and each Type-B input of the
method: angle-error bounds, calibration uncertainties of the amplitude,
overload or reference channel), synthetic data sets are drawn from the
fitted model with those inputs, and each is reduced by the same linear
operators as the measured data (vectorised over trials, no per-trial
Python loop).

A **sampler** is a picklable callable ``sampler(rng, n) -> (n, p)`` that
returns, for ``n`` synthetic data sets, the reduction's error
``e_r = y*_r - y_r``: what the reduction returned minus the coefficients
(the measurand) that generated data set ``r``. The distribution of the
measurand given the measured data is then that of ``y_hat - e_r``
(the measurement model ``Y = y_hat - E`` with the error ``E`` propagated
from the input distributions). For a linear reduction with zero-mean
inputs this is exactly the GUM-S1 propagation of the data's distribution
through the reduction; when an input biases the reduction (a neglected
first harmonic, a nonlinear design), the interval is shifted accordingly.

Reported per coefficient: the estimate, the formal standard uncertainty,
the Monte Carlo standard uncertainty (standard deviation of ``e``), the
mean error (bias) and the coverage interval of probability ``p``
(probabilistically symmetric, GUM-S1 7.7; optionally the shortest).

Monte Carlo sampling error: for ``M`` trials the relative standard error of
the Monte Carlo standard uncertainty is about ``1/sqrt(2 (M - 1))`` for a
Gaussian output (0.7 % at ``M = 10^4``); the coverage-interval endpoints
are quantiles of the kept trials (at most
:data:`accelcal.montecarlo.DEFAULT_MAX_KEPT`) and carry a standard error of
about ``sqrt(q (1 - q) / M) / f(x_q)`` [GUM-S1, 7.9].

References
----------
.. [GUM-S1] JCGM 101:2008, Evaluation of measurement data, Supplement 1 to
   the GUM: Propagation of distributions using a Monte Carlo method,
   sections 5.9, 6.4 (rectangular distribution), 7.2 (number of trials),
   7.7 (coverage intervals), 7.9 (adaptive procedure, standard errors).
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.montecarlo import run

UNCERTAINTY_KINDS = ("formal", "mc")
"""Uncertainty kinds: formal (least-squares covariance) or mc (GUM-S1)."""


def check_options(kind: str, trials: int, seed: int) -> None:
    """Check the ``kind`` of uncertainty, ``trials`` and ``seed``.

    Raises
    ------
    AccelcalError
        For an unknown kind, a trial count that is not a positive integer or a
        negative seed.
    """
    if kind not in UNCERTAINTY_KINDS:
        raise AccelcalError(
            f"{kind!r} is unknown; choose one of {', '.join(UNCERTAINTY_KINDS)}",
            parameter="uncertainty",
        )
    if isinstance(trials, bool) or not isinstance(trials, (int, np.integer)) or trials <= 0:
        raise AccelcalError(f"{trials!r} must be a positive integer (e.g. 10000)",
                            parameter="trials")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise AccelcalError(f"{seed!r} must be a non-negative integer", parameter="seed")


def interval_keys(coverage: float) -> tuple[str, str]:
    """Row keys of the coverage interval, e.g. ``ci95_low``, ``ci95_high``."""
    tag = f"{100 * coverage:g}".replace(".", "_")
    return f"ci{tag}_low", f"ci{tag}_high"


@dataclass(frozen=True)
class McUncertainty:
    """Formal and Monte Carlo uncertainty of a reduction's coefficients.

    Attributes
    ----------
    names : tuple of str
        Coefficient names.
    estimate : numpy.ndarray
        The reduction's estimates of the measured data, shape ``(p,)``.
    formal_std : numpy.ndarray
        Formal (least-squares) standard uncertainties.
    mc_std : numpy.ndarray
        Monte Carlo standard uncertainties (standard deviation of the
        propagated error).
    mc_bias : numpy.ndarray
        Mean propagated error (the reduction's bias under the input
        distributions); the distribution of the measurand is centred on
        ``estimate - mc_bias``.
    ci_low, ci_high : numpy.ndarray
        Coverage interval of probability ``coverage``.
    coverage : float
        Coverage probability.
    shortest : bool
        Shortest coverage interval (else probabilistically symmetric).
    trials, seed : int
        Monte Carlo trials and root seed (same seed, same result).
    units : dict
        Unit of each coefficient.
    inputs : tuple of str
        Description of the propagated inputs and their distributions.
    """

    names: tuple[str, ...]
    estimate: np.ndarray
    formal_std: np.ndarray
    mc_std: np.ndarray
    mc_bias: np.ndarray
    ci_low: np.ndarray
    ci_high: np.ndarray
    coverage: float
    shortest: bool
    trials: int
    seed: int
    units: dict = field(default_factory=dict)
    inputs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in ("estimate", "formal_std", "mc_std", "mc_bias", "ci_low", "ci_high"):
            arr = np.array(getattr(self, name), dtype=float)
            if arr.shape != (len(self.names),):
                raise AccelcalError(
                    f"McUncertainty: {name} has shape {arr.shape}, expected ({len(self.names)},)"
                )
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "names", tuple(self.names))

    @property
    def mc_std_error(self) -> np.ndarray:
        """Standard error of :attr:`mc_std` for Gaussian outputs, ``mc_std / sqrt(2 (M - 1))``."""
        return self.mc_std / np.sqrt(2.0 * max(self.trials - 1, 1))

    def columns(self, i: int) -> dict:
        """The Monte Carlo columns of coefficient ``i``: ``mc_std``, ``ci95_low``, ``ci95_high``."""
        low, high = interval_keys(self.coverage)
        return {"mc_std": float(self.mc_std[i]), low: float(self.ci_low[i]),
                high: float(self.ci_high[i])}

    def rows(self) -> list[dict]:
        """One row per coefficient: estimate, std (formal), mc_std, coverage interval, unit."""
        return [
            {"coefficient": n, "estimate": float(self.estimate[i]),
             "std": float(self.formal_std[i]), **self.columns(i),
             "unit": self.units.get(n, "")}
            for i, n in enumerate(self.names)
        ]


def propagate(
    sampler: Callable[[np.random.Generator, int], np.ndarray],
    estimate,
    formal_std,
    *,
    names: Sequence[str],
    trials: int,
    seed: int,
    units: dict | None = None,
    coverage: float = 0.95,
    shortest: bool = False,
    inputs: Sequence[str] = (),
    progress: Callable[[int, int], None] | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    force: bool = False,
) -> McUncertainty:
    """Monte Carlo uncertainty of a reduction (GUM-S1).

    Parameters
    ----------
    sampler : callable
        ``sampler(rng, n)`` -> errors ``y* - y`` of ``n`` re-reduced synthetic
        data sets, shape ``(n, p)`` (see the module docstring). Picklable for
        Dask.
    estimate : array_like, shape (p,)
        Estimates from the measured data (NaN for coefficients the design
        cannot identify: their Monte Carlo columns are NaN too).
    formal_std : array_like, shape (p,)
        Formal standard uncertainties.
    names : sequence of str
        Coefficient names.
    trials : int
        Monte Carlo trials (> 0).
    seed : int
        Root seed (>= 0).
    units : dict, optional
        Unit of each coefficient.
    coverage : float
        Coverage probability (0.95).
    shortest : bool
        Shortest coverage interval instead of the probabilistically symmetric one.
    inputs : sequence of str
        Description of the propagated inputs (kept in the result).
    progress, workers, scheduler
        Passed to :func:`accelcal.montecarlo.run`.
    force : bool
        Run even when the trials are estimated to take more than
        :data:`accelcal.work.MAX_SECONDS` (the first task is timed; refused
        otherwise, with the estimate).

    Returns
    -------
    McUncertainty

    Raises
    ------
    AccelcalError
        For a non-positive trial count, a negative seed, a coverage
        probability outside (0, 1) or mismatched shapes.

    References
    ----------
    .. [1] JCGM 101:2008 (GUM-S1), 7.2-7.7.
    """
    names = tuple(names)
    y = np.asarray(estimate, dtype=float).reshape(-1)
    s = np.asarray(formal_std, dtype=float).reshape(-1)
    if y.size != len(names) or s.size != len(names):
        raise AccelcalError(
            f"{len(names)} names for {y.size} estimates and {s.size} standard uncertainties"
        )
    if not 0.0 < coverage < 1.0:
        raise AccelcalError(f"coverage probability {coverage} must be between 0 and 1")
    from accelcal.work import MAX_SECONDS

    result = run(sampler, trials, names=names, seed=seed, keep_samples=True, progress=progress,
                 workers=workers, scheduler=scheduler,
                 max_seconds=None if force else MAX_SECONDS)
    err = result.coverage_interval(coverage, shortest=shortest)  # GUM-S1 7.7
    # Y = y_hat - E: the interval of Y is y_hat minus the reversed interval of E.
    low, high = y - err[:, 1], y - err[:, 0]
    undetermined = ~np.isfinite(y)
    nan = np.where(undetermined, np.nan, 0.0)
    return McUncertainty(
        names=names, estimate=y, formal_std=s, mc_std=result.std + nan,
        mc_bias=result.mean + nan, ci_low=low + nan, ci_high=high + nan,
        coverage=float(coverage), shortest=bool(shortest), trials=result.trials,
        seed=int(seed), units=dict(units or {}), inputs=tuple(inputs),
    )
