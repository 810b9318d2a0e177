"""The still-recording simulator: each IEEE 952 term alone gives its analytic Allan variance.

Measured against the analytic AVAR (IEEE 952 Annex C, Eqs. (C.1)-(C.5)) at
several taus, with a tolerance of 4 standard deviations of the measured
Allan variance: ``sqrt(2 / edf)`` relative, the chi-square spread of the
point's EDF (Greenhall-Riley for the identified noise), so a correct
simulator fails with probability ~1e-4 per point.
"""

import math

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.formats import noise as noise_format
from accelcal.methods.noise.fit import FACTORS, model_avar
from accelcal.rigs.noise import (
    B_RANGE_RIPPLE,
    bias_model,
    gauss_markov_avar,
    simulate,
    simulate_blocks,
)
from accelcal.signal.allan.deviations import deviation

RATE = 100.0


def _check(coefs, duration, seed=1, taus=None, extra=None):
    rec = simulate(**coefs, rate=RATE, duration=duration, seed=seed)
    dev = deviation(rec.values[:, 0], RATE, kind="oadev", taus="octave")
    want = model_avar(coefs, dev.tau) + (0 if extra is None else extra(dev.tau))
    got = dev.dev**2
    sel = np.ones(dev.tau.size, bool) if taus is None else taus(dev.tau)
    tol = 4 * np.sqrt(2 / dev.edf)
    bad = np.abs(got / want - 1)[sel] > tol[sel]
    assert not bad.any(), (dev.tau[sel][bad], (got / want)[sel][bad], tol[sel][bad])
    return dev


def test_white_noise_gives_n2_over_tau():
    _check({"N": 2e-5}, 600.0)


def test_quantisation_gives_3q2_over_tau2():
    _check({"Q": 1e-6}, 300.0)


def test_random_walk_gives_k2_tau_over_3_with_the_sampling_term():
    # discrete random walk: AVAR = K^2 tau / 3 (1 + 1 / (2 m^2)) (derived in the module)
    K = 1e-5
    _check({"K": K}, 600.0, extra=lambda tau: K**2 * (1 / RATE) ** 2 / (6 * tau))


def test_ramp_gives_r2_tau2_over_2_exactly():
    rec = simulate(R=1e-6, rate=RATE, duration=100.0)
    dev = deviation(rec.values[:, 0], RATE, taus="octave")
    np.testing.assert_allclose(dev.dev**2, FACTORS["R"] * 1e-12 * dev.tau**2, rtol=1e-6)


def test_bias_instability_floor_is_0664_b_in_the_stated_range():
    B = 5e-6
    duration = 2000.0
    dev = _check({"B": B}, duration, seed=4,
                 taus=lambda tau: (tau >= 30 / RATE) & (tau <= duration / 4),
                 extra=lambda tau: 0 * tau)
    assert dev.dev.size > 5


def test_bias_model_is_flat_to_the_stated_ripple():
    # analytic: the Gauss-Markov sum's AVAR over the stated range (independent of sampling)
    corr, var = bias_model(1.0, RATE, 0.3, 3000.0)
    taus = np.geomspace(0.3, 3000.0, 400)
    avar = sum(gauss_markov_avar(taus, var, t) for t in corr)
    floor = 2 * math.log(2) / math.pi
    assert np.max(np.abs(avar / floor - 1)) < B_RANGE_RIPPLE


def test_gauss_markov_avar_against_simulation():
    # one AR(1) process, T = 2 s at 100 Hz: measured AVAR within 4 SD of the closed form
    T, v = 2.0, 1.0
    phi = math.exp(-1 / (RATE * T))
    rng = np.random.default_rng(3)
    from scipy.signal import lfilter

    e = rng.standard_normal(400_000) * math.sqrt(v * (1 - phi**2))
    y = lfilter([1.0], [1.0, -phi], e)
    dev = deviation(y, RATE, taus="octave")
    sel = (dev.tau >= 0.1) & (dev.tau <= 200)
    want = gauss_markov_avar(dev.tau, v, T)
    assert np.all(np.abs(dev.dev**2 / want - 1)[sel] < 4 * np.sqrt(2 / dev.edf[sel]))


def test_blocks_concatenate_to_the_record_and_carry_state():
    # a random walk stays continuous across blocks: no jump at the block boundary
    blocks = list(simulate_blocks(K=1e-4, rate=RATE, duration=10.0, seed=2, block=300))
    assert [b.size for b in blocks] == [300, 300, 300, 100]
    y = np.concatenate(blocks)
    steps = np.abs(np.diff(y))
    assert steps[299] < 6 * 1e-4 * math.sqrt(1 / RATE)


def test_record_round_trip_csv_and_parquet(tmp_path):
    rec = simulate(N=1e-5, rate=RATE, duration=2.0, seed=5, unit="m/s^2")
    for name in ("r.csv", "r.parquet"):
        noise_format.write(tmp_path / name, rec)
        back = noise_format.read(tmp_path / name)
        np.testing.assert_array_equal(back.values, rec.values)
        assert back.rate == RATE
        assert back.unit == "m/s^2"
        assert back.metadata["true"]["N"] == 1e-5
        assert back.metadata["simulated"] is True


@pytest.mark.parametrize("kwargs", [{"N": -1.0}, {"N": math.nan}, {"duration": 0.0},
                                    {"rate": -5.0}, {"duration": 1e12}])
def test_bad_settings_refused(kwargs):
    args = {"rate": RATE, "duration": 1.0, **kwargs}
    with pytest.raises(AccelcalError):
        simulate(**args)
