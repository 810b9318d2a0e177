"""Coverage harness: are the uncertainties a reduction states honest? (issue 11)

For one method (a subclass of :class:`contract.ReductionContract`: ``truth``,
``simulate``, ``reduce``, ``expected``) :func:`coverage` runs ``N`` simulated
experiments (seeds ``0 .. N-1``, each a new random truth and new noise, the
method's settings as its contract runs them) and reports, per coefficient
(pooled over the sensors of a multi-sensor reduction):

``sd_ratio``
    the empirical standard deviation of ``estimate - truth`` divided by the
    mean stated standard uncertainty (target 0.9-1.1). "Mean" is the root
    mean square (the square root of the mean stated variance): it is the
    plain mean where every experiment states the same SD (a fixed design
    with a given noise), and it stays unbiased where the stated SD varies
    from experiment to experiment, as it does with a random truth (a tumble
    states SDs in g from an output-unit noise, so they scale as 1 / K1 and
    K1 is drawn from 0.5-3: the plain mean would make an honest method look
    1.14x optimistic) or with a variance estimated from residuals (the mean
    of ``s`` is biased low by c4(dof); the mean of ``s**2`` is not);
``coverage``
    the fraction of experiments whose stated 95 % interval
    ``estimate +- k std`` holds the truth, with ``k`` the 97.5 % point of
    Student's t for the Reduction's ``dof`` (the degrees of freedom of a
    variance estimated from residuals, GUM G.3) when ``dof > 0``, else
    1.96; where the reduction propagates Type B priors, of the row's
    Welch-Satterthwaite dof (``Reduction.dof_eff``) (target 0.93-0.97).

:func:`cases` lists what the standing check runs: every contract subclass of
``tests/methods/*/test_*_contract.py`` (found by import, so a method added later joins
by writing its contract) plus :data:`EXTRA_CASES`, settings a user reaches
that the contracts do not run (the library's default where a contract
chooses an option, designs with few degrees of freedom, ...): one line each.

Used by ``tests/uncertainty/test_coverage.py`` (slow tests, targets asserted) and
``benchmarks/coverage.py`` (the table of docs/coverage.md).
"""

import importlib.util
import inspect
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType
from typing import ClassVar

import numpy as np

from accelcal.interval import coverage_factor
from helpers.contract import ReductionContract
from helpers.paths import TESTS

SD_RATIO_TARGET = (0.9, 1.1)
"""Target of empirical SD / mean stated SD (issue 11)."""

COVERAGE_TARGET = (0.93, 0.97)
"""Target of the coverage of the stated 95 % interval (issue 11)."""

DEFAULT_EXPERIMENTS = 400
"""Simulated experiments per case (issue 11: at least 400)."""


@dataclass(frozen=True)
class CoefficientCoverage:
    """Coverage statistics of one coefficient of one case.

    Attributes
    ----------
    case : str
        ``module.Class`` of the contract (or the extra case's name).
    coefficient : str
        Coefficient name (pooled over sensors).
    sd_ratio : float
        Empirical SD of ``estimate - truth`` over the RMS stated SD.
    coverage : float
        Fraction of scores with ``|estimate - truth| <= k std``.
    mean_z : float
        Mean of ``(estimate - truth) / std``: a bias in stated SDs.
    scores : int
        Number of (experiment, sensor) scores pooled.
    experiments : int
        Number of experiments that gave a result.
    k : float
        Coverage factor used (of the first experiment; the same for all when
        the design is fixed).
    sd_ratio_se : float
        Standard error of ``sd_ratio`` from the run itself: the squared
        ratio ``R^2 = mean(e^2) / mean(s^2)`` is a ratio estimator, whose
        variance is ``var(e_i^2 - R^2 s_i^2) / (N mean(s^2)^2)`` [Cochran]_
        (with the sample's own moments, so it holds where the stated SDs
        vary with the truth, e.g. 6x for the tumble's K3 with K1, and the
        errors with them; where they vary by estimation noise of few
        degrees of freedom; and for heavy-tailed errors), halved by the
        square root. Equal stated SDs and Gaussian errors give the
        relative ``1 / sqrt(2N)``.

    References
    ----------
    .. [Cochran] Cochran W. G., Sampling Techniques, 3rd ed., Wiley, 1977,
       eq. (6.9) (variance of a ratio estimator).
    """

    case: str
    coefficient: str
    sd_ratio: float
    coverage: float
    mean_z: float
    scores: int
    experiments: int
    k: float
    sd_ratio_se: float


@dataclass(frozen=True)
class CaseCoverage:
    """All coefficients of one case, the run time and the experiments that failed."""

    case: str
    coefficients: dict[str, CoefficientCoverage]
    experiments: int
    seconds: float
    failures: tuple[tuple[int, str], ...]
    """(seed, exception) of experiments whose reduction raised or stated a non-finite or
    non-positive SD: every one is a defect of the method (reported, not ignored)."""


def coverage(contract: ReductionContract, n: int | None = None, *,
             name: str | None = None, seeds=None) -> CaseCoverage:
    """Run ``n`` simulated experiments of ``contract`` and measure its stated uncertainty.

    Parameters
    ----------
    contract : ReductionContract
        An instance of a contract subclass.
    n : int, optional
        Number of experiments (seeds ``0 .. n-1`` unless ``seeds`` is given);
        default the contract's ``EXPERIMENTS`` attribute if it has one (a case
        whose statistics need more), else :data:`DEFAULT_EXPERIMENTS`.
    name : str, optional
        Case name (default ``module.Class`` of the contract).
    seeds : iterable of int, optional
        Explicit seeds.

    Returns
    -------
    CaseCoverage
    """
    cls = type(contract)
    name = name or f"{cls.__module__}.{cls.__qualname__}"
    if n is None:
        n = getattr(contract, "EXPERIMENTS", DEFAULT_EXPERIMENTS)
    seeds = list(range(n)) if seeds is None else list(seeds)
    err: dict[str, list[float]] = {}
    std: dict[str, list[float]] = {}
    kk: dict[str, list[float]] = {}
    failures = []
    done = 0
    start = time.perf_counter()
    for seed in seeds:
        rng = np.random.default_rng(seed)
        try:
            truth = contract.truth(rng)
            red = contract.reduce(contract.simulate(truth, rng, True))
            rows = []
            for s, want in enumerate(contract.expected(truth)):
                est = red.sensors[s]
                for coef, value in want.items():
                    sd = est.std_of(coef)
                    if not (np.isfinite(sd) and sd > 0 and np.isfinite(est[coef])):
                        raise ValueError(f"sensor {s} {coef}: estimate {est[coef]!r}, std {sd!r}")
                    # k of the row's Welch-Satterthwaite dof: its Type B priors meet the
                    # reduction's Type A dof (the reduction's dof where it has no Type B)
                    dof = red.dof_eff(coef, s) if red.type_b else red.dof
                    want_row = contract.row_truth(truth, est.label(coef), value)
                    rows.append((coef, est[coef] - want_row, sd, coverage_factor(dof)))
        except Exception as exc:  # a defect to report, not to hide
            failures.append((seed, f"{type(exc).__name__}: {exc}"[:300]))
            continue
        done += 1
        for coef, e, sd, k in rows:
            err.setdefault(coef, []).append(e)
            std.setdefault(coef, []).append(sd)
            kk.setdefault(coef, []).append(k)
    seconds = time.perf_counter() - start
    out = {}
    for coef, errors in err.items():
        e, s, k = np.asarray(errors), np.asarray(std[coef]), np.asarray(kk[coef])
        ratio, se = sd_ratio(e, s) if done > 1 else (math.nan, math.nan)
        out[coef] = CoefficientCoverage(
            case=name, coefficient=coef, sd_ratio=ratio,
            coverage=float(np.mean(np.abs(e) <= k * s)), mean_z=float(np.mean(e / s)),
            scores=int(e.size), experiments=done, k=float(k[0]), sd_ratio_se=se)
    return CaseCoverage(name, out, done, seconds, tuple(failures))


def sd_ratio(errors: np.ndarray, stds: np.ndarray) -> tuple[float, float]:
    """Empirical SD of ``errors`` over the RMS of ``stds``, and its standard error.

    See :attr:`CoefficientCoverage.sd_ratio_se` for the standard error.
    """
    n = errors.size
    e2, s2 = (errors - np.mean(errors)) ** 2 * n / (n - 1), stds**2
    r2 = float(np.mean(e2) / np.mean(s2))  # Eq. (6.9) [Cochran]: a ratio estimator's variance
    if r2 == 0.0:  # every error zero: an exact result (a decided ladder increment)
        return 0.0, 0.0
    var_r2 = float(np.var(e2 - r2 * s2, ddof=1) / (n * np.mean(s2) ** 2))
    return math.sqrt(r2), math.sqrt(var_r2) / (2.0 * math.sqrt(r2))


# ------------------------------------------------------------------------------- the cases
def contract_modules() -> list[ModuleType]:
    """Every contract test module, ``tests/**/test_*_contract.py``, by import.

    They live in ``tests/methods/<method>/``; any folder of tests/ is searched, so a
    contract written elsewhere joins too.
    """
    return [contract_module(path.stem)
            for path in sorted(TESTS.rglob("test_*_contract.py"), key=lambda p: p.name)]


def contract_module(stem: str) -> ModuleType:
    """The contract test module ``tests/**/<stem>.py``, imported once as ``stem``.

    Imported under its file name (as pytest imported the flat tests/ before its
    folders), so that case names stay ``test_vre_contract.TestContract`` and so
    on whether the harness runs in pytest or from benchmarks/coverage.py.
    """
    if stem in sys.modules:
        return sys.modules[stem]
    (path,) = TESTS.rglob(f"{stem}.py")
    spec = importlib.util.spec_from_file_location(stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[stem] = module
    spec.loader.exec_module(module)
    return module


def contract_classes() -> list[type]:
    """Every concrete ReductionContract subclass of the contract test modules.

    Concrete: collected by pytest (class name ``Test*``), defined in that module.
    """
    found = []
    for module in contract_modules():
        for obj_name, obj in vars(module).items():
            if (inspect.isclass(obj) and issubclass(obj, ReductionContract)
                    and obj_name.startswith("Test") and obj.__module__ == module.__name__):
                found.append(obj)
    return found


def _four_default():
    """The four-sensor reduction as ``reduce(data, "four")`` runs it: the library's default
    covariance (the contract chooses ``covariance="propagated"``)."""
    TestFourContract = contract_module("test_dividing_head_contract").TestFourContract

    class FourDefault(TestFourContract):
        OPTIONS: ClassVar[dict] = {}

    return FourDefault()


def _tumble_few_dof():
    """Tumble at 8 positions from 0 deg (``accelcal tumble simulate --points 8``), noise from
    the residuals: 1 degree of freedom (OA, 7 terms). The start stays at 0: from a random
    start the 4th harmonic of 8 positions vanishes near 4 start = 90 deg and K0, K2, K4 are
    then barely identifiable (stated SDs of every size, correctly, but no SD ratio)."""
    TestContractFourierOA = contract_module("test_tumble_contract").TestContractFourierOA

    from accelcal.rigs.tumble import uniform_positions

    class TumbleEight(TestContractFourierOA):
        # one degree of freedom: a stated variance scatters by sqrt(2) of itself, so the SD
        # ratio of 400 experiments has an SE of ~7 %; 4000 bring it to ~2.5 % (20 s)
        EXPERIMENTS = 4000

        def positions(self, rng):
            return uniform_positions(8)

    return TumbleEight()


def _vre_cli(sampling: str):
    """VRE identification as ``accelcal vre simulate`` then ``vre fit`` run it by default
    (18 points b = 1, 2, 4 g x A = 5..10 g, 50 Hz, 5000 Hz for 1 s, phase 0, noise the
    default model's sigma, 1e-6 g), with ``--sampling`` ``sampling``."""
    contracts = contract_module("test_vre_contract")
    PAPER_A = contracts.PAPER_A
    PAPER_B = contracts.PAPER_B
    TestContract = contracts.TestContract

    from accelcal.rigs.vibrafuge import simulate

    class VreCli(TestContract):
        def simulate(self, truth, rng, noisy):
            return simulate(truth, PAPER_B, PAPER_A, frequency=50.0,
                            sample_rate=5000.0, duration=1.0, phase=0.0,
                            noise=1e-6 if noisy else 0.0, sampling=sampling, rng=rng)

    return VreCli()


def _noise_all_terms():
    """``accelcal noise fit --terms Q,N,B,K,R`` (the default before N,K): every IEEE 952 term
    fitted, on the contract's still recordings (N and K only: Q, B and R are zero, at their
    bound). The CLI default, N,K, is the contract itself."""
    contracts = contract_module("test_noise_contract")
    RATE = contracts.RATE
    TestContract = contracts.TestContract

    from accelcal.methods.noise.fit import TERMS, fit, fit_deviation

    class NoiseAllTerms(TestContract):
        def reduce(self, data):
            if isinstance(data, np.ndarray):
                return fit(data, RATE, terms=TERMS, unit="g")
            return fit_deviation(data, terms=TERMS)

    return NoiseAllTerms()


def _thermal_auto_order():
    """``accelcal thermal reduce`` by default: the polynomial order chosen by the F-test."""
    AutoOrder = contract_module("test_thermal_contract").AutoOrder

    return AutoOrder()


def _triad_unknown_eighteen():
    """The gravity norm on the demo's design (the six axis directions and 12 random ones,
    counts): 9 degrees of freedom, the Student-t coverage factor at work."""
    TestContractGravityNorm = contract_module("test_triad_contract").TestContractGravityNorm

    from accelcal.rigs.triad import random_directions, six_positions

    class TriadEighteen(TestContractGravityNorm):
        def directions(self, rng):
            return np.vstack([six_positions(), random_directions(12, rng)])

    return TriadEighteen()


def _triad_cli_default():
    """``accelcal triad simulate --positions 24`` then ``triad calibrate`` with its defaults:
    static intervals detected (30 s still period, 1 s window, 2 s shortest), the threshold
    factor chosen by the calibration residual, the gravity norm with the intervals' own
    noise (counts, 100 Hz, 5 s per position, 2 s motions)."""
    contracts = contract_module("test_triad_contract")
    G = contracts.G
    TestContractGravityNorm = contracts.TestContractGravityNorm

    from accelcal.methods.triad.threshold import choose_factor
    from accelcal.rigs.triad import random_directions, simulate

    class TriadCli(TestContractGravityNorm):
        def simulate(self, truth, rng, noisy):
            return simulate(truth, random_directions(24, rng), rate=100.0, dwell=5.0,
                            motion=2.0, still=30.0, noise_sd=self.NOISE if noisy else 0.0,
                            seed=rng, gravity=G)

        def reduce(self, data):
            return choose_factor(data.acc, 100.0, G, init_static=30.0, window=1.0,
                                 min_length=2.0, input_unit=data.input_unit).reduction

    return TriadCli()


def _triad_exact_magnitudes():
    """The gravity norm of every-term truths with each pendulous term at exactly the default
    magnitude (random sign), as the other methods' truths: against the default prior
    (+-2a rectangular) the biases, whose Type B is about 44 % of their variance, are
    conservative by the arithmetic of docs/coverage.md."""
    TestContractEveryTermGravityNorm = \
        contract_module("test_triad_contract").TestContractEveryTermGravityNorm

    from helpers.contract import default_terms

    class TriadExact(TestContractEveryTermGravityNorm):
        terms = staticmethod(default_terms)

    return TriadExact()


EXTRA_CASES: dict[str, Callable[[], ReductionContract]] = {
    "dividing-head four, default covariance": _four_default,
    "tumble fourier OA, 8 positions (1 dof)": _tumble_few_dof,
    "vre identify, CLI defaults, integrating": lambda: _vre_cli("integrating"),
    "vre identify, CLI defaults, point sampling": lambda: _vre_cli("point"),
    "noise fit, every term (--terms Q,N,B,K,R)": _noise_all_terms,
    "thermal reduce, CLI default order auto": _thermal_auto_order,
    "triad gravity norm, 18 positions (9 dof)": _triad_unknown_eighteen,
    "triad calibrate, CLI defaults (detected intervals)": _triad_cli_default,
    "triad gravity norm, every term, exact default magnitudes": _triad_exact_magnitudes,
}
"""Settings users reach that no contract runs: case name -> factory of a contract instance."""


def cases() -> dict[str, Callable[[], ReductionContract]]:
    """Every case of the standing check: case name -> factory of a contract instance."""
    out = {f"{cls.__module__}.{cls.__qualname__}": cls for cls in contract_classes()}
    out.update(EXTRA_CASES)
    return out


# ------------------------------------------------------------------------------ the bands
def coverage_band(experiments: int) -> tuple[float, float]:
    """Band the measured coverage must fall in for the target 0.93-0.97 to be plausible.

    The measured coverage of ``N`` experiments scatters about the true one
    with SD ``sqrt(0.95 * 0.05 / N)`` (0.011 at N = 400; pooled sensors add
    scores but are correlated, so N counts experiments). The test band is
    the target widened by 1.5 of these SDs on each side, so a method whose
    true coverage is 0.95 fails with probability ~1e-3 per coefficient
    (|deviation| > 3.3 SD) while one at 0.90 or 0.99 (2.5-4 SD outside the
    widened band) fails. The script reports the measured numbers against
    the exact target.
    """
    se = math.sqrt(0.95 * 0.05 / experiments)
    return COVERAGE_TARGET[0] - 1.5 * se, COVERAGE_TARGET[1] + 1.5 * se


def sd_ratio_band(c: CoefficientCoverage) -> tuple[float, float]:
    """Band of the measured SD ratio: the target 0.9-1.1 widened by one standard error.

    The standard error is the run's own (``c.sd_ratio_se``): about
    ``1 / sqrt(2N)`` (0.035 at N = 400) for Gaussian errors and equal
    stated SDs, more where they vary or the errors have heavy tails, so an
    honest method (ratio 1) fails with probability ~1e-4 (> 3.8 SE) and one
    at 0.8 or 1.2 fails.
    """
    return SD_RATIO_TARGET[0] - c.sd_ratio_se, SD_RATIO_TARGET[1] + c.sd_ratio_se


def markdown_table(results: list[CaseCoverage]) -> str:
    """The results as a markdown table (one row per case and coefficient)."""
    lines = ["| method | coefficient | SD ratio | coverage | mean z | k | N | seconds | verdict |",
             "|---|---|---:|---:|---:|---:|---:|---:|---|"]  # SD ratio: value +- its SE
    for res in results:
        for c in res.coefficients.values():
            verdict = verdict_of(c)
            lines.append(f"| {res.case} | {c.coefficient} | {c.sd_ratio:.3f} ± {c.sd_ratio_se:.3f} "
                         f"| {c.coverage:.3f} "
                         f"| {c.mean_z:+.3f} | {c.k:.3f} | {c.experiments} | {res.seconds:.1f} "
                         f"| {verdict} |")
        if res.failures:
            lines.append(f"| {res.case} | (failed experiments) | | | | | {len(res.failures)} "
                         f"| | seed {res.failures[0][0]}: {res.failures[0][1][:80]} |")
    return "\n".join(lines) + "\n"


def verdict_of(c: CoefficientCoverage) -> str:
    """``ok`` inside both exact targets; else what misses (and whether the test band holds)."""
    misses = []
    if not SD_RATIO_TARGET[0] <= c.sd_ratio <= SD_RATIO_TARGET[1]:
        lo, hi = sd_ratio_band(c)
        misses.append("SD ratio" + ("" if lo <= c.sd_ratio <= hi else " (beyond test band)"))
    if not COVERAGE_TARGET[0] <= c.coverage <= COVERAGE_TARGET[1]:
        lo, hi = coverage_band(c.experiments)
        misses.append("coverage" + ("" if lo <= c.coverage <= hi else " (beyond test band)"))
    return "ok" if not misses else "misses " + ", ".join(misses)


INTERVAL_NOISES = {2: "white PM", 1: "flicker PM", 0: "white FM", -1: "flicker FM",
                   -2: "random walk FM"}
"""Power-law noises of the deviation-interval coverage (alpha -> name)."""


def interval_coverage(kind: str, alpha: int, trials: int = 1000, samples: int = 4096,
                      seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coverage of the 68.3 % intervals of :func:`accelcal.signal.allan.deviation` per tau.

    ``trials`` series of ``samples`` samples of the power-law noise ``alpha``
    (Kasdin's filter for flicker), octave taus up to ``samples / 4``; the
    truth at each tau is the root mean of the series' variances (unbiased
    estimators: exact in the limit, ~1/sqrt(trials x edf) off at the longest
    tau).

    Returns
    -------
    m, coverage, right : numpy.ndarray
        Averaging factors, share of intervals holding the truth, share of
        series whose alpha at that tau was the true one.
    """
    from accelcal.signal.allan.deviations import DIVISOR, deviation
    from accelcal.signal.allan.identify import alpha_range
    from accelcal.signal.allan.kernels import phase, variance_sums
    from helpers.noise import powerlaw

    rng = np.random.default_rng(seed + 10 * (alpha + 4))
    m = 2 ** np.arange(int(np.log2(samples // 4)) + 1)
    series = [powerlaw(alpha, samples, rng) for _ in range(trials)]
    var = []
    for y in series:
        sums, counts = variance_sums(phase(y), m, kind)
        scale = m.astype(float) ** (4 if kind == "mdev" else 2)  # MDEV: m^2 in the deviation
        var.append(sums / (DIVISOR[kind] * counts) / scale)
    truth = np.sqrt(np.mean(var, axis=0))
    low, high = alpha_range(kind)
    hits, right = np.zeros(m.size), np.zeros(m.size)
    for y in series:
        res = deviation(y, 1.0, kind=kind, taus=m.astype(float))
        hits += (res.lo <= truth) & (truth <= res.hi)
        right += res.alpha == min(max(alpha, low), high)
    return m, hits / trials, right / trials
