"""Every noise fit states its goodness of fit and widens its intervals when the model misses.

A record with a bias-instability floor fitted with N and K alone (the CLI
default) must be told apart from the same record fitted with N, B, K; the
Birge ratio then scales every uncertainty, and the table, JSON and report
say so in words (issue 24, item 5).
"""

import json

import numpy as np
import pytest

from accelcal.methods.noise import fit, report_text
from accelcal.methods.noise.fit import CLI_TERMS, TERMS, coefficients, goodness_of_fit
from accelcal.rigs.noise import simulate
from helpers.cli import run_cli


@pytest.fixture(scope="module")
def floored():
    rec = simulate(N=2e-5, B=5e-6, K=2e-7, rate=100.0, duration=3600.0, seed=1)
    return rec.values[:, 0], rec.rate


def test_a_missing_term_is_reported_and_widens_the_intervals(floored):
    y, rate = floored
    nk = fit(y, rate, terms="N,K", unit="g", psd=False)
    nbk = fit(y, rate, terms="N,B,K", unit="g", psd=False)
    assert not nk.assumed("model_fits")
    assert nk.assumed("uncertainty_scale") == pytest.approx(nk.assumed("birge_ratio"))
    assert nk.assumed("uncertainty_scale") > 1.0
    assert any("does not describe the record" in n for n in nk.notes)
    assert "does NOT describe the record" in report_text(nk).summary
    assert nbk.assumed("model_fits")
    assert nbk.assumed("uncertainty_scale") == 1.0
    chi2, dof = nbk.assumed("goodness_of_fit")
    assert dof == nbk.observations["tau"].size - 3
    assert 0.0 < chi2 < 3.0 * dof


def test_chi_square_uses_the_covariance_and_scales_by_the_birge_ratio():
    sigma = np.array([[4.0, 2.0], [2.0, 4.0]])
    r = np.array([2.0, -2.0])
    gof = goodness_of_fit(r, sigma, 0)
    assert gof["chi2"] == pytest.approx(r @ np.linalg.solve(sigma, r))  # 4, not 2
    assert gof["dof"] == 2
    assert gof["birge"] == pytest.approx(np.sqrt(2.0))
    assert gof["fits"] == (gof["p"] >= 0.05)


def test_cli_default_is_n_k_and_prints_the_goodness_of_fit(tmp_path, capsys):
    still = str(tmp_path / "still.parquet")
    code, _, err = run_cli(["noise", "simulate", "--N", "2e-5", "--K", "2e-7", "--rate", "50",
                            "--duration", "600", "--seed", "3", "--out", still], capsys)
    assert code == 0, err
    code, out, err = run_cli(["noise", "fit", still, "--format", "json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert {"N", "K", "chi2", "chi2_dof", "birge_ratio", "model_fits"} <= set(doc)
    assert "B" not in doc
    assert [t for t in TERMS if t in doc] == list(CLI_TERMS)
    assert "Q" not in doc
    code, out, err = run_cli(["noise", "fit", still, "--terms", "Q,N,B,K,R"], capsys)
    assert code == 0, err
    assert "goodness of fit: chi^2" in out
    assert "at the bound 0" in out


def test_bound_terms_are_named(floored):
    y, rate = floored
    red = fit(y, rate, terms="Q,N,B,K,R", unit="g", psd=False)
    doc = coefficients(red)
    assert set(doc["at_bound"]) == set(red.assumed("at_bound"))
    assert all(t in report_text(red).summary for t in doc["at_bound"])
