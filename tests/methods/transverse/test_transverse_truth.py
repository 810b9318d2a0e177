"""The shaker identification's rows equal their truths with every term non-zero.

The embedded default accelerometer on a shaker whose own motion has a part
along IA (measured by the reference channels): the terms of a_i (K2, K3,
Kio, Kip, K0', K1') then reach the output, the fit takes them as zero, and
their default priors, propagated as Type B, must cover what they move.
"""

import numpy as np
import pytest

import accelcal
from accelcal.errors import AccelcalError
from accelcal.methods.transverse import identify
from accelcal.rigs.shaker import ShakerRig

THETA = np.deg2rad(np.arange(0.0, 360.0, 30.0))
FITTED = ("Ko", "Kp", "Koo", "Kpp", "Kop")


def _records(ratio: float):
    rig = ShakerRig(amplitude=5.0, gravity=1.0, rest=True, frequency=160.0,
                    sample_rate=10240.0, periods=4.0, noise=0.0, transverse_ratio=ratio,
                    transverse_direction=np.pi / 2, transverse_phase=0.3,
                    measure_transverse=True)
    return rig.simulate(accelcal.default_model(), THETA)


@pytest.mark.parametrize("route", ["2w", "dc", "both", "w"])
def test_ia_motion_terms_are_bounded_by_their_priors(route):
    model = accelcal.default_model()
    data = _records(0.05)
    red = identify(data, route=route)
    bare = identify(data, route=route, priors="none")
    # K2 and K1' (|a_i|: DC and 2w only) do not reach the w phasor
    seen = {"K3", "Kio", "Kip", "K0_asym"} | (set() if route == "w" else {"K2", "K1_asym"})
    assert {p.name for p in red.priors} == seen
    assert any("bounded by priors" in n for n in red.notes)
    for name in FITTED:
        err = abs(red.estimate[name] - getattr(model, name))
        # Ko, Kp within 0.87 SD (one term, Kio: 1 / (2 / sqrt 3)); Koo, Kpp up to 1.35 SD,
        # where K0', K2 and K1' move them the same way (their priors independent)
        assert err <= 1.5 * red.estimate.std_of(name), name
    # without the priors Ko is off by 1 ug/g, hundreds of its stated SDs
    assert abs(bare.estimate["Ko"] - model.Ko) > 100 * bare.estimate.std_of("Ko")
    assert bare.type_b == ()
    assert {a.term for a in bare.aliases} == seen | (set() if route == "w" else {"K4"})


def test_the_aliases_are_what_a_held_term_moves():
    model = accelcal.default_model()
    data = _records(0.05)
    bare = identify(data, priors="none")
    held = identify(data, base=model.replace(**dict.fromkeys(FITTED, 0.0)))
    assert held.type_b == ()  # every term of a_i held: nothing left to bound
    for name in FITTED:
        predicted = sum(a.sensitivity * getattr(model, a.term) for a in bare.aliases
                        if a.row == name)
        moved = bare.estimate[name] - held.estimate[name]
        # the sampled square wave of K0' differs from its Fourier series by ~1/64
        assert moved == pytest.approx(predicted, rel=0.05, abs=1e-12), name


def test_the_asymmetry_regressors_are_the_fourier_series():
    # held at their true values, every term of a_i removed: the rows are their truths
    # within the sampled square wave's departure (a few 1e-3 ug/g^2 on Koo, Kpp)
    model = accelcal.default_model()
    held = identify(_records(0.05), route="both",
                    base=model.replace(**dict.fromkeys(FITTED, 0.0)))
    for name in FITTED:
        assert abs(held.estimate[name] - getattr(model, name)) < 2e-9, name


def test_without_ia_motion_nothing_is_left_to_bound():
    red = identify(_records(0.0))
    assert red.type_b == ()
    assert red.aliases == ()


def test_bad_priors_are_refused():
    with pytest.raises(AccelcalError, match="priors"):
        identify(_records(0.0), priors="some")


def test_priors_given_as_numbers_are_the_users_standard_uncertainties():
    data = _records(0.05)
    red = identify(data, priors={"Kio": 1e-5, "Ko": 1.0})
    assert [(p.name, p.value, p.distribution, p.source) for p in red.priors] == \
        [("Kio", 1e-5, "normal", "user")]  # Ko is fitted: its prior is not used
    with pytest.raises(AccelcalError, match="not a term of the shaker model"):
        identify(data, priors={"Kx": 1e-5})
