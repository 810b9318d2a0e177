"""Temperature polynomials, order selection, warm-up, compensation and the model's temperature
terms (issue 15 items 1, 3, 4), each against an independent route."""

import json

import numpy as np
import pytest

from accelcal import ErrorModel
from accelcal.errors import AccelcalError, ModelFileError
from accelcal.methods.thermal import Compensation, fit_polynomial, fit_warmup
from accelcal.terms import TemperatureTerms
from helpers.cli import run_cli

DT = np.array([-65.0, -50.0, -35.0, -20.0, -5.0, 10.0, 25.0, 45.0, 35.0, 20.0, 0.0, -30.0])
DIRS = np.array([-1, 1, 1, 1, 1, 1, 1, 1, -1, -1, -1, -1])


def test_weighted_fit_is_numpy_polyfit_with_weights():
    rng = np.random.default_rng(1)
    s = rng.uniform(1.0, 3.0, DT.size)
    y = 1.0 + 0.02 * DT - 3e-4 * DT**2 + 0.4 * 0.5 * DIRS + rng.normal(0, s)
    fit = fit_polynomial(y, s, DT, DIRS, order=2)
    # numpy.polyfit takes w = 1/sigma and with cov="unscaled" gives (A'WA)^-1; the hysteresis
    # column is removed first by the fit's own H (same normal equations, partitioned)
    yh = y - 0.5 * DIRS * fit.values[-1]
    coef, cov = np.polyfit(DT, yh, 2, w=1 / s, cov="unscaled")
    np.testing.assert_allclose(fit.values[:3], coef[::-1], rtol=1e-10)
    chi2 = np.sum(((y - fit.fitted) / s) ** 2)
    assert fit.chi2 == pytest.approx(chi2, rel=1e-12)
    assert fit.dof == DT.size - 4
    # the partitioned covariance is larger than polyfit's (H estimated too): check H's
    # variance by the Schur complement route instead
    A = np.column_stack([DT**0, DT, DT**2, 0.5 * DIRS]) / s[:, None]
    # the covariance is scaled by the Birge ratio squared only when it exceeds 1
    full = np.linalg.inv(A.T @ A) * max(chi2 / fit.residual_dof, 1.0)
    np.testing.assert_allclose(fit.covariance, full, rtol=1e-9)
    assert cov.shape == (3, 3)


def test_order_selection_finds_the_order_and_stops():
    rng = np.random.default_rng(2)
    s = np.full(DT.size, 1e-3)
    hits = {1: 0, 2: 0, 3: 0}
    for _ in range(200):
        y = 2e-3 * DT + 2e-6 * DT**2 + rng.normal(0, 1e-3, DT.size)  # order 2, strong
        hits[fit_polynomial(y, s, DT, DIRS, order="auto").order] += 1
    # the quadratic term is ~8 SD: always found; the cubic F-test rejects falsely at ~5 %
    assert hits[1] == 0
    assert 0.01 <= hits[3] / 200 <= 0.11


def test_too_few_plateaus_are_refused():
    with pytest.raises(AccelcalError, match="at least 3 plateaus"):
        fit_polynomial([1.0, 2.0], [1.0, 1.0], [0.0, 10.0], [1, 1])
    with pytest.raises(AccelcalError, match="order 3 needs") as exc:
        fit_polynomial([1.0, 2.0, 3.0, 4.0], [1.0] * 4, [0.0, 10.0, 20.0, 30.0], [1] * 4,
                       order=3)
    assert exc.value.parameter == "order"


def test_warmup_fit_recovers_the_transient_within_its_uncertainty():
    rng = np.random.default_rng(3)
    t = np.arange(1, 181) * 10.0
    z = []
    for _ in range(200):
        y = 1.3 + 6.5e-5 * np.exp(-t / 300.0) + rng.normal(0, 2e-5, t.size)
        w = fit_warmup(t, y)
        z.append((w.values - [1.3, 6.5e-5, 300.0]) / np.sqrt(np.diag(w.covariance)))
    z = np.array(z)
    # 200 fits: the SD of z is 1 +- 0.05 (first-order covariance of a mildly nonlinear fit;
    # 0.85-1.2 allows its small curvature bias)
    assert np.all((z.std(axis=0) > 0.85) & (z.std(axis=0) < 1.2)), z.std(axis=0)
    with pytest.raises(AccelcalError, match=r"exponential|within 3 standard"):
        fit_warmup(t, 1.3 + rng.normal(0, 2e-5, t.size))


TT = TemperatureTerms(20.0, {"K0_T1": 3e-6, "K0_T2": -2e-8, "K1_T1": -4e-5, "K1_T3": 1e-9,
                             "Kp_T1": 1e-7}, (-40.0, 80.0))
MODEL = ErrorModel(K0=2e-4, K1=1.25, Kp=3e-5, temperature=TT)


def test_terms_at_temperature_by_hand():
    t = np.array([-40.0, 20.0, 55.0])
    d = t - 20.0
    c = MODEL.terms_at(t)
    np.testing.assert_allclose(c["K0"], 2e-4 + 3e-6 * d - 2e-8 * d**2, rtol=1e-15)
    np.testing.assert_allclose(c["K1"], 1.25 * (1 - 4e-5 * d + 1e-9 * d**3), rtol=1e-15)
    np.testing.assert_allclose(c["Kp"], 3e-5 + 1e-7 * d, rtol=1e-14)
    assert c["K2"] == 0.0
    at = MODEL.at_temperature(55.0)
    assert at.temperature is None
    assert at.output(1.0, 0.0, 0.5) == pytest.approx(
        float(MODEL.output(1.0, 0.0, 0.5, temperature=55.0)), rel=1e-15)
    with pytest.raises(AccelcalError, match="outside the model's valid range"):
        MODEL.output(1.0, temperature=90.0)
    # a model without temperature terms ignores the temperature (and checks it)
    plain = ErrorModel(K0=1e-4)
    assert plain.output(1.0, temperature=60.0) == plain.output(1.0)
    with pytest.raises(AccelcalError):
        plain.output(1.0, temperature=float("nan"))


def test_model_file_with_temperature_round_trips_and_old_files_load(tmp_path):
    path = tmp_path / "m.json"
    MODEL.save(path)
    doc = json.loads(path.read_text())
    assert doc["format_version"] == 2
    assert doc["temperature"]["units"]["K1_T3"] == "1/degC^3"
    assert ErrorModel.load(path) == MODEL
    plain = ErrorModel(K0=1e-4)
    assert json.loads(plain.to_json())["format_version"] == 1
    assert "temperature" not in plain.to_json()
    doc["temperature"]["units"]["K0_T1"] = "ug/degC"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match=r"units\.K0_T1"):
        ErrorModel.load(path)
    doc["format_version"] = 1
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="need format_version 2"):
        ErrorModel.load(path)


def test_compensation_inverts_the_model_along_ia(tmp_path):
    comp = Compensation.from_model(MODEL)
    t = np.linspace(-40.0, 80.0, 25)
    a = np.linspace(-1.0, 1.0, 25)
    e = MODEL.output(a, temperature=t)  # Kp does not act along IA alone
    got, flag = comp.apply(e, t)
    np.testing.assert_allclose(got, a, rtol=0, atol=1e-15)
    assert not flag.any()
    comp.save(tmp_path / "c.json")
    assert Compensation.load(tmp_path / "c.json") == comp
    with pytest.raises(AccelcalError, match=r"outside the compensation's valid range"):
        comp.apply(e, t + 1.0)
    _, flag = comp.apply(e, t + 1.0, allow_extrapolation=True)
    assert flag.sum() == 1


def test_model_commands_carry_temperature(tmp_path, capsys):
    path = tmp_path / "m.json"
    code, _, err = run_cli(["model", "new", "--set", "K1=1.2", "--set", "K0_T1=2e-6",
                            "--set", "K1_T1=-3e-5", "--set", "T0=20", "--out", path], capsys)
    assert code == 0, err
    model = ErrorModel.load(path)
    assert model.temperature == TemperatureTerms(20.0, {"K0_T1": 2e-6, "K1_T1": -3e-5})
    code, out, _ = run_cli(["model", "show", path, "--format", "csv"], capsys)
    assert "T0,20.0,degC" in out
    assert "K1_T1,-3e-05,1/degC" in out
    code, out, _ = run_cli(["model", "eval", "--model", path, "--ai", "1",
                            "--temperature", "0,20,40", "--format", "json"], capsys)
    rows = json.loads(out)
    assert [r["temperature_degC"] for r in rows] == [0.0, 20.0, 40.0]
    want = model.output(1.0, temperature=np.array([0.0, 20.0, 40.0]))
    np.testing.assert_array_equal([r["output_V"] for r in rows], want)
    # K1(T) = 1.2 (1 - 3e-5 dT), K0(T) = 2e-6 dT: output_g = 1 + K0(T) by hand
    assert rows[2]["output_g"] == pytest.approx(1.0 + 2e-6 * 20.0, rel=1e-14)
