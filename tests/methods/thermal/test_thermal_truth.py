"""The thermal reduction's rows are what their names say, for the default accelerometer.

Noise-free plateaus of the embedded default accelerometer (every term non-zero):
the rows at T0 are K0+Kpp and K2-Kpp, and K1 (which carries K0') is within its
stated uncertainty because K0' and K1' are bounded by their priors (Type B).
"""

import numpy as np
import pytest

import accelcal
from accelcal.methods.thermal import reduce_thermal
from accelcal.methods.thermal.poly import fit_polynomial
from accelcal.rigs.thermal import Programme, simulate

PROGRAMME = Programme(setpoints=(-40.0, -10.0, 20.0, 50.0, 70.0, 35.0, 5.0, -25.0),
                      soak=3600.0, warmup=600.0, points=12, dwell=30.0, step=10.0)


@pytest.fixture(scope="module")
def default_run():
    model = accelcal.default_model()
    rec = simulate(model, PROGRAMME, tau=0.0, noise=0.0, temperature_noise=0.0, seed=1)
    return model, reduce_thermal(rec, order=1)


def test_rows_at_t0_equal_their_truth_within_their_uncertainty(default_run):
    m, red = default_run
    truth = {"K0+Kpp": m.K0 + m.Kpp, "K1": m.K1, "K2-Kpp": m.K2 - m.Kpp, "Kp": m.Kp}
    rows = {r["coefficient"]: r for r in red.rows()}
    for name, want in truth.items():
        assert abs(rows[name]["estimate"] - want) <= rows[name]["std"], name
    assert rows["K0+Kpp"]["plain"] == "K0"


def test_k1_carries_k0_asymmetry_and_says_so(default_run):
    m, red = default_run
    (k1,) = [c for c in red.contributions("K1") if c.input == "K0_asym"]
    none = reduce_thermal(simulate(m, PROGRAMME, tau=0.0, noise=0.0, temperature_noise=0.0,
                                   seed=1), order=1, priors=None)
    # K0' moves K1 by 2.5 ppm of the default accelerometer at 12 positions (2.8 at 24)
    err = none.value("K1") - m.K1
    assert err / m.K1 > 2e-6
    assert err == pytest.approx(k1.sensitivity * m.K0_asym, rel=1e-2)
    assert not none.type_b
    assert any(a.term == "K0_asym" and a.row == "K1" for a in none.aliases)
    assert red.std("K1") > 2 * none.std("K1")


def test_birge_ratio_scales_up_only():
    dt = np.linspace(-60, 45, 8)
    dirs = np.zeros(8)
    rng = np.random.default_rng(2)
    s = np.full(8, 1.0)
    quiet = fit_polynomial(1 + 0.1 * dt + 0.3 * rng.standard_normal(8), s, dt, dirs, order=1,
                           weights_dof=200)
    assert quiet.birge < 1
    assert quiet.dof == 200  # the weights' own dof
    unscaled = np.linalg.inv(np.column_stack([dt**0, dt]).T @ np.column_stack([dt**0, dt]))
    np.testing.assert_allclose(quiet.covariance, unscaled, rtol=1e-9)
    loud = fit_polynomial(1 + 0.1 * dt + 3.0 * rng.standard_normal(8), s, dt, dirs, order=1,
                          weights_dof=200)
    assert loud.birge > 1
    assert loud.dof == 6
    np.testing.assert_allclose(loud.covariance, unscaled * loud.birge**2, rtol=1e-9)


def test_plateau_temperature_uncertainty_widens_the_temperature_coefficient(default_run):
    m = accelcal.default_model().replace(
        temperature=accelcal.model.TemperatureTerms(25.0, {"K0_T1": 5e-6}))
    rec = simulate(m, PROGRAMME, tau=0.0, noise=2e-5, temperature_noise=0.0, seed=3)
    plain = reduce_thermal(rec, order=1, temperature_sd=0.0)
    wide = reduce_thermal(rec, order=1, temperature_sd=0.5)
    assert wide.provenance["temperature_sd"] == [0.5] * 8
    assert wide.std("K0_T1") > plain.std("K0_T1")


def test_rows_of_a_kept_plateau_covariance_are_said_conservative():
    # at order 2 the plateaus' noise carries the drift during each tumble: where the Birge
    # ratio keeps their covariance, the note names every row of that polynomial and why
    rec = simulate(accelcal.default_model(), PROGRAMME, tau=600.0, noise=2e-5,
                   temperature_noise=0.01, seed=4)
    red = reduce_thermal(rec, order=2)
    (note,) = [n for n in red.notes if "95 % intervals conservative" in n]
    rows = note.split(":")[0].split(", ")
    birge = red.provenance["birge_ratio"]
    kept = [b for b, r in birge.items() if r <= 1.0]
    assert kept
    for b in birge:
        mine = {red.estimate.label(b), f"{b}_T1", f"{b}_T2"}
        assert mine <= set(rows) if b in kept else not mine & set(rows)
    assert "Birge ratio scales it up only" in note
    assert "drift" in note
