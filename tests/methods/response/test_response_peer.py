"""The second-order fit against PyDynamic's ``fit_som`` on the same points (a peer route).

PyDynamic (PTB) fits ``S0 / (1 + 2 i delta f / f0 - (f / f0)^2)`` by linear
least squares on the reciprocal ``1 / H``, with a Monte Carlo of the points'
covariance; accelcal fits ``H`` itself by weighted non-linear least squares.
Both estimators are consistent: noise-free points give both the truth, and
noisy ones give estimates that differ by less than the stated standard
uncertainty. PyDynamic is a test-only reference (archived since 2024, in the
``test`` extra only): the test is skipped, with the reason, where it stops
installing.
"""

import numpy as np
import pytest

from accelcal.methods.response import fit_model, reduce
from accelcal.rigs.shaker_response import DutResponse, simulate


@pytest.fixture(scope="module")
def fit_transfer():
    """PyDynamic's fitting module, imported when a test runs (not at collection: ~1-3 s)."""
    return pytest.importorskip(
        "PyDynamic.model_estimation.fit_transfer",
        reason="PyDynamic (a test-only peer, archived since 2024) is not installed")

FREQUENCIES = (10.0, 40.0, 80.0, 160.0, 315.0, 500.0, 630.0, 800.0, 1000.0, 1250.0)


def _peer(fit_transfer, red, mc_runs=2000):
    f = red.observations["frequency_hz"]
    h = np.asarray(red.estimate.values)
    n = f.size
    cov = np.zeros((2 * n, 2 * n))  # PyDynamic orders [Re..., Im...]
    blocks = red.estimate.covariance
    for i in range(n):
        for a in range(2):
            for b in range(2):
                cov[a * n + i, b * n + i] = blocks[2 * i + a, 2 * i + b]
    np.random.seed(1)  # noqa: NPY002 (fit_som draws from numpy's global generator)
    pars, u_pars = fit_transfer.fit_som(f, np.r_[h.real, h.imag], UH=cov, weighting="cov",
                                        MCruns=mc_runs)
    return pars, np.sqrt(np.diag(u_pars))  # S0, delta (zeta), f0


def test_noise_free_both_fits_give_the_truth(fit_transfer):
    dut = DutResponse(S0=1.3, fn_hz=600.0, zeta=0.6)
    red = reduce(simulate(dut, frequencies=FREQUENCIES, noise=1e-7, seed=0))
    est = fit_model(red).estimate
    ours = dict(zip(est.names, est.values, strict=True))
    pars, _ = _peer(fit_transfer, red, mc_runs=200)
    assert [ours["S0"], ours["fn"], ours["zeta"]] == pytest.approx([1.3, 600.0, 0.6], rel=1e-5)
    assert pars == pytest.approx([1.3, 0.6, 600.0], rel=1e-4)


def test_noisy_fits_agree_within_the_stated_uncertainty(fit_transfer):
    dut = DutResponse(S0=1.3, fn_hz=600.0, zeta=0.6)
    red = reduce(simulate(dut, frequencies=FREQUENCIES, noise=3e-3, periods=10, seed=3))
    est = fit_model(red).estimate
    ours = dict(zip(est.names, est.values, strict=True))
    std = dict(zip(est.names, est.std, strict=True))
    pars, u_pars = _peer(fit_transfer, red)
    peer = {"S0": pars[0], "zeta": pars[1], "fn": pars[2]}
    u_peer = {"S0": u_pars[0], "zeta": u_pars[1], "fn": u_pars[2]}
    for name in ("S0", "fn", "zeta"):
        assert abs(ours[name] - peer[name]) < std[name], name
        # the two covariances agree to the Monte Carlo's and the linearisation's precision
        assert u_peer[name] / std[name] == pytest.approx(1.0, abs=0.5), name
