"""Monte Carlo engine: reproducibility across chunking and workers, statistics, errors."""

import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal import AccelcalError
from accelcal import montecarlo as mc


class LinearFit:
    """Least-squares errors of a quadratic fit to 24 noisy points (a linear-Gaussian study)."""

    def __init__(self, sigma=0.05):
        t = np.linspace(0, 1, 24)
        self.design = np.column_stack([np.ones(24), t, t**2])
        self.operator = np.linalg.pinv(self.design)
        self.sigma = sigma

    def formal_covariance(self):
        return self.sigma**2 * np.linalg.inv(self.design.T @ self.design)

    def __call__(self, rng, n):
        return rng.normal(0.0, self.sigma, (n, 24)) @ self.operator.T


NAMES = ("a", "b", "c")


@settings(max_examples=15, deadline=None)
@given(
    trials=st.integers(1, 3000),
    block_size=st.integers(1, 700),
    tasks=st.tuples(st.integers(1, 9), st.integers(1, 9)),
)
def test_bit_identical_for_any_blocks_per_task(trials, block_size, tasks):
    study = LinearFit()
    a, b = (
        mc.run(study, trials, names=NAMES, seed=7, block_size=block_size,
               blocks_per_task=k, keep_samples=True, max_kept=500)
        for k in tasks
    )
    for field in ("mean", "rms", "std", "covariance", "samples"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert a.trials == trials


def test_statistics_match_numpy_on_all_trials():
    study = LinearFit()
    res = mc.run(study, 5000, names=NAMES, seed=1, block_size=333, keep_samples=True,
                 max_kept=10**6)
    # The kept samples are every trial, in order: the same draws the engine saw.
    every = np.concatenate([study(mc.block_generator(1, b), min(333, 5000 - 333 * b))
                            for b in range(-(-5000 // 333))])
    np.testing.assert_array_equal(res.samples, every)
    # Streaming (pairwise-merged) moments vs two-pass numpy: rounding only.
    np.testing.assert_allclose(res.mean, every.mean(axis=0), rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(res.covariance, np.cov(every.T), rtol=1e-11)
    np.testing.assert_allclose(res.rms, np.sqrt((every**2).mean(axis=0)), rtol=1e-12)


def test_linear_gaussian_scatter_matches_formal_covariance():
    study = LinearFit()
    res = mc.run(study, 200_000, names=NAMES, seed=3)
    # Relative SE of a variance from 2e5 trials: sqrt(2/2e5) = 0.3 %; allow 1.5 %.
    np.testing.assert_allclose(np.diag(res.covariance), np.diag(study.formal_covariance()),
                               rtol=0.015)
    assert np.all(np.abs(res.mean) < 5 * res.std / np.sqrt(res.trials))


def test_thinning_and_coverage_interval():
    study = LinearFit()
    res = mc.run(study, 100_000, names=NAMES, seed=4, keep_samples=True, max_kept=20_000)
    assert len(res.samples) == 20_000  # stride 5 over 100 000 trials
    ci = res.coverage_interval(0.95)
    # Gaussian outputs: the 95 % interval is mean +- 1.95996 sd; 2 % relative
    # tolerance covers the quantile's sampling error at 2e4 samples (~1 %).
    half = 1.959964 * np.sqrt(np.diag(study.formal_covariance()))
    np.testing.assert_allclose(ci[:, 1], half, rtol=0.03)
    np.testing.assert_allclose(ci[:, 0], -half, rtol=0.03)
    short = res.coverage_interval(0.95, shortest=True)
    assert np.all(short[:, 1] - short[:, 0] <= ci[:, 1] - ci[:, 0] + 1e-15)


def test_dask_workers_give_identical_results():
    pytest.importorskip("distributed")
    study = LinearFit()
    local = mc.run(study, 20_000, names=NAMES, seed=9, block_size=1000, keep_samples=True)
    dask2 = mc.run(study, 20_000, names=NAMES, seed=9, block_size=1000, keep_samples=True,
                   workers=2, blocks_per_task=3)
    for field in ("mean", "rms", "covariance", "samples"):
        np.testing.assert_array_equal(getattr(local, field), getattr(dask2, field))


def test_progress_reports_every_trial():
    seen = []
    mc.run(LinearFit(), 1000, names=NAMES, seed=0, block_size=100, blocks_per_task=3,
           progress=lambda done, total: seen.append((done, total)))
    assert seen[-1] == (1000, 1000)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        # the library names its parameters (the command line maps them to its options)
        ({"trials": 0}, "trials: must be a positive integer"),
        ({"trials": -5}, "trials: must be a positive integer"),
        ({"trials": 2.5}, "trials: must be a positive integer"),
        ({"seed": -1}, "seed: -1 must be a non-negative integer"),
        ({"block_size": 0}, "block_size: must be a positive integer"),
        ({"workers": 0}, "workers: must be a positive integer"),
        ({"workers": 2, "scheduler": "tcp://127.0.0.1:1"}, "either workers or a scheduler"),
    ],
)
def test_bad_arguments(kwargs, message):
    args = {"trials": 10, "names": NAMES, "seed": 1, **kwargs}
    trials = args.pop("trials")
    with pytest.raises(AccelcalError, match=message):
        mc.run(LinearFit(), trials, **args)


def test_wrong_output_shape_is_reported():
    with pytest.raises(AccelcalError, match=r"returned shape \(10, 3\) for 10 trials; expected"):
        mc.run(LinearFit(), 10, names=("a", "b"), seed=1)


def test_unreachable_scheduler_fails_within_timeout():
    pytest.importorskip("distributed")
    import time

    start = time.monotonic()
    with pytest.raises(AccelcalError, match="did not answer within 1 s"):
        mc.run(LinearFit(), 10, names=NAMES, seed=1, scheduler="tcp://127.0.0.1:9",
               timeout=1.0)
    assert time.monotonic() - start < 15  # the stated timeout, plus cluster teardown slack


def test_variances_only_match_the_full_covariance():
    study = LinearFit()
    full = mc.run(study, 3000, names=NAMES, seed=2, block_size=400)
    diag = mc.run(study, 3000, names=NAMES, seed=2, block_size=400, covariance=False)
    np.testing.assert_array_equal(diag.mean, full.mean)
    # Diagonal by einsum vs by matrix product: the same sums, rounding apart.
    np.testing.assert_allclose(diag.rms, full.rms, rtol=1e-13)
    np.testing.assert_allclose(diag.std, full.std, rtol=1e-13)
    assert np.isnan(diag.covariance[0, 1])
    np.testing.assert_allclose(np.diag(diag.covariance), np.diag(full.covariance), rtol=1e-13)


def test_moments_hold_no_view_of_a_blocks_outputs():
    # A zero-length view would keep every block's whole output array alive.
    values = np.ones((1000, 3))
    for stride in (0, 7):
        kept = mc._Moments.of(values, 0, stride, True).kept
        assert kept.base is None or kept.base is not values
        assert not np.shares_memory(kept, values)


class _Stop(Exception):
    pass


def test_a_huge_trial_count_starts_at_once_and_reports_progress():
    # 1e12 trials: the tasks are made on demand (no list of 3e7 ranges first), so the
    # run starts streaming within milliseconds; it would be a long run, not a crash.
    calls = []

    def progress(done, total):
        calls.append((done, total))
        if len(calls) == 3:
            raise _Stop

    start = time.perf_counter()
    with pytest.raises(_Stop):
        mc.run(LinearFit(), 10**12, names=NAMES, seed=1, progress=progress)
    assert time.perf_counter() - start < 5.0
    assert calls[0][1] == 10**12
    assert calls[0][0] < calls[2][0]


class StreamedFit(LinearFit):
    """The same study handing its outputs to the engine in pieces of 100 trials."""

    def pieces(self, rng, n):
        values = self(rng, n)
        for start in range(0, n, 100):
            yield values[start:start + 100]


def test_streamed_pieces_match_one_array():
    """A study with ``pieces`` gives the statistics of the same trials as one array: the
    pieces' moments merged in order (rounding only) and the same kept samples."""
    kw = {"names": NAMES, "seed": 4, "block_size": 700, "keep_samples": True, "max_kept": 500}
    for covariance in (True, False):
        whole = mc.run(LinearFit(), 3000, covariance=covariance, **kw)
        streamed = mc.run(StreamedFit(), 3000, covariance=covariance, **kw)
        np.testing.assert_array_equal(whole.samples, streamed.samples)
        np.testing.assert_allclose(streamed.mean, whole.mean, rtol=1e-12, atol=1e-17)
        np.testing.assert_allclose(streamed.rms, whole.rms, rtol=1e-12)
        np.testing.assert_allclose(streamed.std, whole.std, rtol=1e-12)


class _ShortPieces(LinearFit):
    def pieces(self, rng, n):
        yield self(rng, n - 1)


def test_pieces_of_the_wrong_count_are_reported():
    with pytest.raises(AccelcalError, match="the study returned 99 trials; expected 100"):
        mc.run(_ShortPieces(), 100, names=NAMES, seed=1, block_size=100)


def test_variances_keep_precision_when_the_mean_dominates():
    """Outputs of mean 1e8 and SD 1: ``sum x^2 - n mean^2`` would lose every digit; those rows
    are centred first, so the variances match numpy's two-pass ones (rtol 1e-9)."""
    rng = np.random.default_rng(5)
    rows = np.vstack([1e8 + rng.standard_normal(4000), rng.standard_normal(4000)])
    mean, m2 = mc._output_moments(rows)
    np.testing.assert_allclose(m2 / 4000, rows.var(axis=1), rtol=1e-9)
    np.testing.assert_allclose(mean, rows.mean(axis=1), rtol=1e-15)
