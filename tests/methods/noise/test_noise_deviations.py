"""Allan-family deviations, tau sets and noise identification (issue 13).

Independent routes: NIST SP 1065's published values for its NBS14 data set;
allantools (a test-only dependency) on the same series; direct sums over
block averages of the samples (no cumulative sums); simulated power-law
noises of known exponent; Monte Carlo coverage of the intervals.
"""

import allantools
import numpy as np
import pytest

from accelcal import AccelcalError
from accelcal.signal.allan.deviations import KINDS, Deviation, compute, deviation
from accelcal.signal.allan.identify import ACF_MIN_POINTS, alpha_range, noise_alphas
from accelcal.signal.allan.kernels import phase
from accelcal.signal.allan.taus import max_m, min_samples, n_terms, tau_grid, taus_to_m
from helpers.noise import powerlaw


def nbs14_1000() -> np.ndarray:
    """NBS14 1000-point frequency data: the Lehmer generator n <- 16807 n mod (2^31 - 1)
    seeded with 1234567890, divided by 2^31 - 1 (SP 1065 sec. 12, p. 107; allantools
    tests/nbs14/test_nbs14_1000point.py)."""
    n = [1234567890]
    for _ in range(999):
        n.append(16807 * n[-1] % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]  # printed in SP 1065
    return np.array(n, dtype=float) / 2147483647


# NIST SP 1065 (Riley 2008) p. 108, "1000-point test suite" values at tau = 1, 10, 100
# (TOTDEV: the doubly reflected TOTVAR method); the same table is in allantools'
# tests/nbs14/test_nbs14_1000point.py (nbs14_1000_devs).
NBS14_1000 = {
    "adev": (2.922319e-01, 9.965736e-02, 3.897804e-02),
    "oadev": (2.922319e-01, 9.159953e-02, 3.241343e-02),
    "mdev": (2.922319e-01, 6.172376e-02, 2.170921e-02),
    "totdev": (2.922319e-01, 9.134743e-02, 3.406530e-02),
    "hdev": (2.943883e-01, 1.052754e-01, 3.910860e-02),
    "ohdev": (2.943883e-01, 9.581083e-02, 3.237638e-02),
}


@pytest.mark.parametrize("kind", KINDS)
def test_nbs14_1000_point_values_of_sp1065(kind):
    tau, m, _, dev = compute(nbs14_1000(), 1.0, kind, [1, 10, 100])
    assert list(m) == [1, 10, 100]
    assert np.array_equal(tau, [1.0, 10.0, 100.0])
    # SP 1065 prints 7 significant figures: half a unit of the last is <= 5e-7 relative
    assert dev == pytest.approx(NBS14_1000[kind], rel=5e-7)


def _series(n: int, seed: int) -> np.ndarray:
    """A still accelerometer: 1 g offset, white noise, a random walk and a slow drift (m/s^2)."""
    rng = np.random.default_rng(seed)
    walk = np.cumsum(rng.normal(scale=2e-7, size=n))
    return 9.80665 + rng.normal(scale=3e-5, size=n) + walk + 1e-9 * np.arange(n)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("spec", ["octave", "decade", "all"])
def test_agrees_with_allantools_for_every_kind_and_tau_set(kind, spec):
    y = _series(1500, 13)
    rate = 200.0
    tau, m, n, dev = compute(y, rate, kind, spec)
    t_ref, d_ref, _, n_ref = getattr(allantools, kind)(y, rate=rate, data_type="freq", taus=spec)
    if kind == "totdev":  # allantools goes on to m = N; accelcal stops at N/2 (Stable32)
        keep = np.round(t_ref * rate) <= max_m(len(y), kind)
        t_ref, d_ref, n_ref = t_ref[keep], d_ref[keep], n_ref[keep]
    assert np.array_equal(m, np.round(t_ref * rate).astype(int))
    assert np.array_equal(n, n_ref)
    assert np.array_equal(n, n_terms(len(y), m, kind))
    # same sums in a different order (chunked dot products): 1e-10 leaves 1e5 x rounding
    assert dev == pytest.approx(d_ref, rel=1e-10)
    assert tau == pytest.approx(t_ref, rel=1e-15)


def _block_means(y: np.ndarray, m: int, start: int = 0) -> np.ndarray:
    k = (len(y) - start) // m
    return y[start:start + k * m].reshape(k, m).mean(axis=1)


def _direct(y: np.ndarray, m: int, kind: str) -> float:
    """SP 1065's definitions from averages of the samples, by plain loops."""
    n = len(y)
    if kind == "adev":  # Eq. (6): non-overlapping averages
        yb = _block_means(y, m)
        return np.sqrt(0.5 * np.mean(np.diff(yb) ** 2))
    if kind == "hdev":  # Eq. (17)
        yb = _block_means(y, m)
        return np.sqrt(np.mean(np.diff(yb, 2) ** 2) / 6.0)
    if kind in ("oadev", "ohdev", "totdev"):  # averages from every start sample
        yb = np.array([y[j:j + m].mean() for j in range(n - m + 1)])
        if kind == "oadev":
            return np.sqrt(0.5 * np.mean((yb[m:] - yb[:-m]) ** 2))
        if kind == "ohdev":
            return np.sqrt(np.mean((yb[2 * m:] - 2 * yb[m:-m] + yb[:-2 * m]) ** 2) / 6.0)
        # totdev, Eq. (25): phase reflected about both ends, by an explicit loop
        x = np.concatenate([[0.0], np.cumsum(y)])
        big = len(x)

        def star(i):  # 0-based x*_i
            if i < 0:
                return 2 * x[0] - x[-i]
            if i >= big:
                return 2 * x[-1] - x[2 * (big - 1) - i]
            return x[i]

        terms = [star(i - m) - 2 * star(i) + star(i + m) for i in range(1, big - 1)]
        return np.sqrt(np.sum(np.square(terms)) / (2.0 * m * m * (big - 2)))
    # mdev, frequency form of Eq. (14): averages of m overlapping m-sample averages
    yb = np.array([y[j:j + m].mean() for j in range(n - m + 1)])
    terms = [np.mean(yb[j + m:j + 2 * m] - yb[j:j + m]) for j in range(n - 3 * m + 2)]
    return np.sqrt(0.5 * np.mean(np.square(terms)))


@pytest.mark.parametrize("kind", KINDS)
def test_cumulative_sum_kernels_match_the_definitions(kind):
    y = np.random.default_rng(5).normal(size=240)
    _, m, _, dev = compute(y, 1.0, kind, [1, 2, 3, 5, 16, max_m(240, kind)])
    expected = [_direct(y, int(k), kind) for k in m]
    assert dev == pytest.approx(expected, rel=1e-11)


def test_mdev_moving_sums_carried_or_cumulated_give_the_definition(monkeypatch):
    """Factors reached by carrying the phase's moving sums (doublings, single steps, a
    restart from A_1) and factors too far from any (255: seven doublings and seven steps;
    300; 320) that take the cumulative sum of second differences: all as the definition."""
    from accelcal.signal.allan import kernels

    far = []
    cumulated = kernels.mdev_sumsq
    monkeypatch.setattr(kernels, "mdev_sumsq",
                        lambda x, m, work: far.append(m) or cumulated(x, m, work))
    y = np.random.default_rng(6).normal(size=1000) + 9.8
    factors = [1, 2, 4, 6, 12, 255, 256, 300, 320]
    _, m, _, dev = compute(y, 1.0, "mdev", factors)
    assert list(m) == factors
    assert far == [255, 300, 320]  # 320: eight doublings and a step, one over
    assert dev == pytest.approx([_direct(y, k, "mdev") for k in factors], rel=1e-11)


def test_mean_is_removed_before_the_cumulative_sum():
    """A 1 g offset on 1e-5 m/s^2 noise: without the mean the cumulated phase reaches
    2e5 and its rounding (~4e-11) would spoil the short-tau deviations at 1e-6."""
    rng = np.random.default_rng(2)
    noise = rng.normal(scale=1e-5, size=20_000)
    *_, plain = compute(noise, 100.0, "oadev", "octave")
    *_, offset = compute(noise + 9.80665, 100.0, "oadev", "octave")
    # the offset sample itself rounds at 9.8 x 1.1e-16 = 1e-15, 1e-10 of the noise
    assert offset == pytest.approx(plain, rel=1e-8)


def test_tau_sets():
    assert list(tau_grid(1000, "octave", kind="oadev")) == [1, 2, 4, 8, 16, 32, 64, 128, 256]
    assert list(tau_grid(1000, "decade", kind="oadev")) == [1, 2, 4, 10, 20, 40, 100, 200, 400]
    assert list(tau_grid(9, "all", kind="oadev")) == [1, 2, 3, 4]
    for kind in KINDS:
        for n in (4, 5, 17, 1000, 1001):
            top = max_m(n, kind)
            assert n_terms(n, top, kind) >= 2
            assert np.array_equal(tau_grid(n, "all", kind=kind), np.arange(1, top + 1))
            if kind != "totdev":
                assert n_terms(n, top + 1, kind) < 2
    assert max_m(1000, "totdev") == 500
    for kind in KINDS:  # the shortest record with one tau, and one sample fewer
        short = min_samples(kind)
        _, m, n, dev = compute(np.arange(short, dtype=float) ** 2, 1.0, kind)
        assert list(m) == [1]
        assert n[0] >= 2
        assert dev[0] > 0
        with pytest.raises(AccelcalError, match="too few") as err:
            tau_grid(short - 1, "octave", kind=kind)
        assert err.value.parameter == "values"


def test_taus_in_seconds():
    assert list(taus_to_m([0.001, 0.3, 2.0], 1000.0)) == [1, 300, 2000]
    assert list(taus_to_m(0.3, 10.0)) == [3]
    with pytest.raises(AccelcalError, match="whole multiple") as err:
        taus_to_m([0.0015], 1000.0)
    assert err.value.parameter == "taus"
    with pytest.raises(AccelcalError, match="shorter than the sample interval"):
        taus_to_m([0.0001], 1000.0)
    with pytest.raises(AccelcalError) as err:
        taus_to_m([0.1], 0.0)
    assert err.value.parameter == "rate"


@pytest.mark.parametrize(("call", "parameter", "text"), [
    (lambda: compute([1.0, np.nan, 2.0, 3.0, 4.0], 1.0), "values", "sample 1 is nan"),
    (lambda: compute(np.r_[np.zeros(10), np.inf], 1.0), "values", "sample 10 is inf"),
    (lambda: compute(np.full(100, 9.81), 1.0), "values", "the signal is constant"),
    (lambda: compute(np.ones((10, 3)), 1.0), "values", "1-D"),
    (lambda: compute([1.0, 2.0], 1.0), "values", "too few"),
    (lambda: compute(["a", "b", "c"], 1.0), "values", "not a series"),
    (lambda: compute(np.arange(10.0), -1.0), "rate", "sample rate .* must be a number from"),
    (lambda: compute(np.arange(10.0), np.nan), "rate", "sample rate .* must be a number from"),
    (lambda: compute(np.arange(10.0), 1.0, "tdev"), "kind", "unknown deviation"),
    (lambda: compute(np.arange(10.0), 1.0, "oadev", "weekly"), "taus", "unknown tau set"),
    (lambda: compute(np.arange(10.0), 1.0, "oadev", [5]), "taus", "too long"),
    (lambda: compute(np.arange(10.0), 1.0, "oadev", [1.5]), "taus", "not an integer"),
    (lambda: deviation(np.arange(10.0), 1.0, taus=[0.5]), "taus", "shorter"),
    (lambda: deviation(np.arange(10.0), 1.0, confidence=1.0), "confidence", "between"),
    (lambda: deviation(np.arange(10.0), 1.0, alpha=-3), "alpha", "integer from -2"),
])
def test_bad_input_is_refused_on_one_line(call, parameter, text):
    with pytest.raises(AccelcalError, match=text) as err:
        call()
    assert err.value.parameter == parameter
    assert "\n" not in str(err.value)


def test_deviation_rows_and_intervals():
    y = _series(4000, 1)
    res = deviation(y, 100.0, kind="oadev", taus="decade", unit="m/s^2", confidence=0.95)
    assert isinstance(res, Deviation)
    rows = res.rows()
    assert len(rows) == 10  # 1, 2, 4 ... 1000 samples: decade up to (4000 - 1) / 2
    assert [list(r) for r in rows] == [["tau_s", "n", "alpha", "dev", "dev_low", "dev_high"]] * 10
    assert [r["tau_s"] for r in rows] == pytest.approx(res.m / 100.0)
    assert all(r["dev_low"] < r["dev"] < r["dev_high"] for r in rows)
    assert (res.samples, res.unit, res.confidence) == (4000, "m/s^2", 0.95)
    narrow = deviation(y, 100.0, kind="oadev", taus="decade", confidence=0.683)
    assert np.all(narrow.hi - narrow.lo < res.hi - res.lo)
    given = deviation(y, 100.0, taus=[0.01, 0.1], alpha=-1)
    assert list(given.alpha) == [-1, -1]
    with pytest.raises(ValueError, match="read-only"):
        res.dev[0] = 0.0




@pytest.mark.parametrize(("alpha", "share"), [(2, 0.8), (0, 0.8), (-1, 0.55), (-2, 0.8)])
def test_noise_identification_recovers_simulated_exponents(alpha, share):
    """Lag-1 ACF taus (>= 30 block averages) of 4 series of 8192 samples (36 taus): the
    right type at most taus, one type off at worst at nearly all. Over seeds the share
    right is 86-100 % (white PM, white FM, random walk FM) and 64-67 % for flicker FM,
    the hard case: the lag-1 autocorrelation of 30-100 flicker averages is biased toward
    the random walk's (Riley & Greenhall 2004). The thresholds sit ~2 binomial SD of 36
    draws below the lowest share seen."""
    rng = np.random.default_rng(100 + alpha)
    found = []
    for _ in range(4):
        y = powerlaw(alpha, 1 << 13, rng)
        m = tau_grid(len(y), "octave", kind="oadev")
        m = m[len(y) // m >= ACF_MIN_POINTS]
        found.extend(noise_alphas(phase(y), m, "oadev"))
    found = np.array(found)
    assert np.mean(found == alpha) >= share
    assert np.mean(np.abs(found - alpha) <= 1) >= 0.95


@pytest.mark.parametrize("kind", ["oadev", "hdev"])
@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
def test_noise_identification_agrees_with_allantools(kind, alpha):
    """Same published algorithm as allantools.autocorr_noise_id on frequency data, whose
    result accelcal clips to the exponents the kind converges for."""
    y = powerlaw(alpha, 4096, np.random.default_rng(7 - alpha))
    m = tau_grid(len(y), "octave", kind=kind)
    m = m[len(y) // m >= ACF_MIN_POINTS]
    ours = noise_alphas(phase(y), m, kind)
    dmax = 3 if kind == "hdev" else 2
    low, high = alpha_range(kind)
    ref = [allantools.autocorr_noise_id(y, int(k), data_type="freq", dmax=dmax)[0] for k in m]
    assert list(ours) == [min(max(a, low), high) for a in ref]


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_intervals_cover_the_true_deviation_of_white_noise(kind):
    """White FM of unit variance: AVAR = HVAR = TOTVAR = 1/m exactly; MVAR = |c|^2/(2 m^4)
    with c the weights of one MDEV term on the samples. The 68.3 % interval at m = 16
    (64 block averages: the lag-1 ACF identifies the noise) must hold the truth in
    68.3 % of 1000 records, within 3 binomial SD = 3 sqrt(0.683 x 0.317 / 1000) = 0.044."""
    rng = np.random.default_rng(2003)
    m, trials = 16, 1000
    c = np.convolve(np.ones(m), np.r_[-np.ones(m), np.ones(m)])
    truth = np.sqrt(c @ c / (2 * m**4) if kind == "mdev" else 1.0 / m)
    hits = 0
    for _ in range(trials):
        res = deviation(rng.normal(size=1024), 100.0, kind=kind, taus=[m / 100.0])
        hits += res.lo[0] <= truth <= res.hi[0]
    assert abs(hits / trials - 0.683) <= 0.044


@pytest.mark.parametrize(("alpha", "share"), [(2, 0.7), (1, 0.55), (0, 0.7), (-2, 0.6)])
def test_b1_and_rn_identify_short_series(alpha, share):
    """25 block averages (N = 100, m = 4): the B1 ratio (Barnes 1969), with R(m) =
    MVAR/AVAR between white and flicker PM. Shares right in 400 series were 0.81, 0.69,
    0.83, 0.74; thresholds ~5 binomial SD (0.023) lower. A random walk is never taken
    for anything whiter than flicker FM (at most 5 % of series)."""
    rng = np.random.default_rng(1969 - alpha)
    found = np.array([noise_alphas(phase(powerlaw(alpha, 100, rng)), [4], "oadev")[0]
                      for _ in range(400)])
    assert np.mean(found == alpha) >= share
    if alpha == -2:
        assert np.mean(found <= -1) >= 0.95


def test_last_taus_take_the_alpha_of_the_shorter_tau():
    """Fewer than 8 block averages: B1 says too little, the shorter tau's alpha is kept."""
    y = np.cumsum(np.random.default_rng(8).normal(size=1000))
    m = tau_grid(len(y), "all", kind="oadev")
    alphas = noise_alphas(phase(y), m, "oadev")
    short = len(y) // m < 8
    last = alphas[~short][-1]
    assert np.all(alphas[short] == last)
    assert short.sum() > 300  # m = 126..499


@pytest.mark.parametrize(("n", "m", "chunk"), [(1000, 1, 64), (1000, 7, 64), (5000, 333, 100),
                                               (50, 16, 4), (49, 16, 3), (20_000, 5, 1 << 15)])
def test_bounded_mdev_sums_equal_the_whole_array_kernel(n, m, chunk, tmp_path):
    # R(m) of the noise identification may run on a streamed record's memmapped phase: the
    # chunked kernel must give the whole-array sums (same terms, summed in another order:
    # a few ulp of a sum of n positive terms, 1e-12 relative is ~1e4 ulp of room)
    from accelcal.signal.allan.kernels import mdev_sumsq, mdev_sumsq_bounded

    x = np.cumsum(np.random.default_rng(n + m).normal(size=n))
    mm = np.memmap(tmp_path / "x.f8", dtype=float, mode="w+", shape=(n,))
    mm[:] = x
    want = mdev_sumsq(x, m, (np.empty(n + 1), np.empty(n + 1)))
    got = mdev_sumsq_bounded(mm, m, chunk)
    assert got[1] == want[1]
    assert got[0] == pytest.approx(want[0], rel=1e-12)
