"""Identification of VRE coefficients from (b, A) designs (contract tests)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal import AccelcalError, ErrorModel
from accelcal.methods.vre import VRE_TERMS, along_ia, identify, reduce_run, vector_vre
from accelcal.outputs import describe
from accelcal.rigs.vibrafuge import simulate

PAPER_B = np.repeat([1.0, 2.0, 4.0], 6)
PAPER_A = np.tile(np.arange(5.0, 11.0), 3)
"""Guan2021 Table 1 grid: b = 1, 2, 4 g and A = 5..10 g."""


@st.composite
def true_models(draw):
    """Navigation-grade magnitudes of the four coefficients of Guan2021 Table 1."""
    def mag(lo, hi):
        return draw(st.floats(lo, hi)) * draw(st.sampled_from([-1.0, 1.0]))

    return ErrorModel(K2=mag(1e-6, 3e-5), K3=mag(1e-8, 1e-6), K0_asym=mag(1e-7, 1e-5),
                      K1_asym=mag(1e-7, 1e-5), K1=1.3)


@settings(max_examples=10, deadline=None)
@given(model=true_models())
def test_contract_noise_free_simulation_recovers_the_truth(model):
    """Draw a model, simulate the vibrafuge grid, reduce, fit: the truth to rounding."""
    run = simulate(model, PAPER_B, PAPER_A, frequency=50.0, sample_rate=1000.0,
                   duration=0.1, phase=0.4, noise=0.0)
    meas = reduce_run(run)
    fit = identify(meas.overload, meas.amplitude, meas.vre)
    assert fit.unidentified() == ()
    for name in ("K2", "K3", "K0_asym", "K1_asym"):
        # VRE exact to ~1e-15 g; the design's sensitivity to K0' is ~1 g/g, so
        # 1e-12 g absolute or 1e-7 relative covers rounding with margin
        assert fit.estimate[name] == pytest.approx(getattr(model, name), rel=1e-7, abs=1e-12)


def test_contract_noisy_simulation_within_the_stated_uncertainty():
    """Noisy records: estimates within 4 standard uncertainties; the weighted
    covariance agrees with the scatter over repeated simulated campaigns."""
    model = ErrorModel(K2=7.87e-6, K3=1.19e-7, K0_asym=2.26e-6, K1_asym=1.45e-6, K1=1.3)
    rng = np.random.default_rng(2021)
    b = np.tile(PAPER_B, 40)
    a = np.tile(PAPER_A, 40)
    run = simulate(model, b, a, frequency=50.0, sample_rate=1000.0, duration=0.2,
                   noise=3e-6, rng=rng)
    meas = reduce_run(run)
    truth = np.array([model.K2, model.K3, model.K0_asym, model.K1_asym])
    estimates, stds = [], []
    for k in range(40):  # 40 campaigns of 18 points each
        sl = slice(18 * k, 18 * (k + 1))
        fit = identify(meas.overload[sl], meas.amplitude[sl], meas.vre[sl], meas.uncertainty[sl])
        estimates.append(fit.estimate.values)
        stds.append(fit.estimate.std)
    estimates, stds = np.array(estimates), np.array(stds)
    z = (estimates - truth) / stds
    assert np.abs(z).max() < 4.5
    # 40 campaigns: the RMS z of each coefficient lies in [0.6, 1.45] with
    # probability > 0.998 when the stated uncertainty is right
    rms = np.sqrt(np.mean(z**2, axis=0))
    assert ((rms > 0.6) & (rms < 1.45)).all(), rms


def test_single_overload_cannot_separate_k2_and_k3():
    """One b: the K2 and K3 columns are proportional; only K2 + 3 b K3 is identified."""
    model = ErrorModel(K2=7.87e-6, K3=1.19e-7, K0_asym=2.26e-6, K1_asym=1.45e-6)
    b, a = np.full(6, 2.0), np.arange(5.0, 11.0)
    y = vector_vre(model, along_ia(b), a)[0]
    fit = identify(b, a, y + np.random.default_rng(1).normal(0, 1e-12, 6))
    assert fit.unidentified() == ("K2", "K3")
    assert np.isnan(fit.estimate["K2"])
    assert np.isnan(fit.estimate.std_of("K3"))
    assert fit.estimate["K0_asym"] == pytest.approx(model.K0_asym, rel=1e-4)
    assert fit.estimate["K1_asym"] == pytest.approx(model.K1_asym, rel=1e-4)
    (combo,) = fit.combinations
    assert dict(combo.weights) == pytest.approx({"K2": 1.0, "K3": 6.0})
    assert combo.value == pytest.approx(model.K2 + 6.0 * model.K3, rel=1e-7)
    assert 0 < combo.std < 1e-11
    assert any("K2 + 6 K3" in note for note in describe(fit))


def test_amplitudes_at_or_below_the_overload_say_nothing_of_asymmetry():
    """A <= |b| everywhere: K0' and K1' produce no VRE and are reported unidentifiable."""
    model = ErrorModel(K2=7.87e-6, K3=1.19e-7, K0_asym=2.26e-6, K1_asym=1.45e-6)
    b = np.repeat([4.0, -5.0], 4)
    a = np.tile([1.0, 2.0, 3.0, 4.0], 2)
    y = vector_vre(model, along_ia(b), a)[0] + np.random.default_rng(2).normal(0, 1e-12, 8)
    fit = identify(b, a, y)
    assert set(fit.unidentified()) == {"K0_asym", "K1_asym"}
    assert fit.combinations == ()
    assert fit.estimate["K2"] == pytest.approx(model.K2, rel=1e-6)


def test_vector_design_identifies_every_rectifying_term():
    """Vibration along several directions and overloads of both signs separate all ten."""
    rng = np.random.default_rng(5)
    terms = {t: rng.uniform(-1e-5, 1e-5) for t in VRE_TERMS}
    terms["K4"] = 1e-8
    model = ErrorModel.from_terms(terms)
    dirs = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, 0, 1], [0, 1, 1]], float)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    b = np.array([-3.0, -1.0, 0.0, 1.0, 2.0, 4.0])
    a = np.array([2.0, 5.0, 8.0])
    D, B, Amp = (x.reshape(-1, *x.shape[3:]) for x in np.broadcast_arrays(
        dirs[:, None, None, :], b[None, :, None, None], a[None, None, :, None]))
    bvec = along_ia(B[:, 0])
    y = vector_vre(model, bvec, Amp[:, 0], D)[0]
    fit = identify(bvec, Amp[:, 0], y + rng.normal(0, 1e-13, y.size), direction=D,
                   terms=VRE_TERMS)
    assert fit.unidentified() == ()
    for t in VRE_TERMS:
        assert fit.estimate[t] == pytest.approx(terms[t], rel=1e-4, abs=1e-10)
    # along IA alone the cross terms cannot be seen
    ia = np.all(D == [1, 0, 0], axis=1)
    fit_ia = identify(bvec[ia], Amp[ia, 0], y[ia] + rng.normal(0, 1e-13, ia.sum()),
                      terms=VRE_TERMS)
    assert set(fit_ia.unidentified()) == {"Koo", "Kpp", "Kio", "Kip", "Kop"}


def test_fixed_terms_are_subtracted():
    """Holding K3 at its value makes K2 identifiable from a single overload."""
    model = ErrorModel(K2=7.87e-6, K3=1.19e-7, K0_asym=2.26e-6, K1_asym=1.45e-6)
    b, a = np.full(6, 1.0), np.arange(5.0, 11.0)
    y = vector_vre(model, along_ia(b), a)[0] + np.random.default_rng(3).normal(0, 1e-12, 6)
    fit = identify(b, a, y, terms=("K2", "K0_asym", "K1_asym"), fixed={"K3": model.K3})
    assert fit.estimate["K2"] == pytest.approx(model.K2, rel=1e-6)
    assert fit.fixed == {"K3": model.K3}
    fixed_row = {"coefficient": "K3", "estimate": model.K3, "std": 0.0, "unit": "g/g^3",
                 "status": "fixed"}
    assert any(fixed_row.items() <= row.items() for row in fit.rows())


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"terms": ("K0",)}, "no rectification error"),
        ({"terms": ("K9",)}, "unknown term"),
        ({"terms": ("K2",), "fixed": {"K2": 0.0}}, "both fitted and fixed"),
        ({"terms": ()}, "at least one"),
        ({"vre": [1.0]}, "same non-zero number"),
        ({"amplitude": [-1.0, 5.0]}, "negative"),
        ({"vre": [np.nan, 1.0]}, "non-finite"),
        ({"amplitude": [0.0, 0.0]}, "identifies none"),
    ],
)
def test_bad_identification_input(kwargs, message):
    args = {"overload": [1.0, 2.0], "amplitude": [5.0, 6.0], "vre": [1e-4, 2e-4], **kwargs}
    with pytest.raises(AccelcalError, match=message):
        identify(args.pop("overload"), args.pop("amplitude"), args.pop("vre"), **args)
