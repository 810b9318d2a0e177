"""The VRE fit's rows equal their truths with every rectifying term non-zero.

The embedded default accelerometer (every term non-zero) vibrated off IA:
the cross-axis terms rectify too. A term the design cannot separate from
the fitted ones is named in the row (``K2+0.01*Kio``); a separable one is
bounded by its prior, propagated as Type B (:mod:`accelcal.methods.vre.unestimated`).
"""

import numpy as np
import pytest

import accelcal
from accelcal.errors import AccelcalError
from accelcal.methods.vre import VRE_TERMS, along_ia, identify, vre_columns
from helpers.contract import true_value

B = np.repeat([1.0, 2.0, 4.0], 6)
A = np.tile(np.arange(5.0, 11.0), 3)
U = np.full(18, 1e-7)
TILTED = (1.0, 0.01, 0.0)
"""One direction 10 mrad off IA towards OA: Kio and Koo rectify in proportion to K2."""
TWO = np.vstack([np.tile([1.0, 0.0, 0.0], (9, 1)), np.tile([1.0, 0.3, 0.2], (9, 1))])
"""Two directions: the cross-axis terms are separable from K2, but not fitted."""


def _vre(model, direction):
    cols = vre_columns(along_ia(B), A, direction)
    return sum(getattr(model, t) * cols[t] for t in VRE_TERMS)


def test_a_term_in_the_span_of_the_fitted_ones_names_the_row():
    model = accelcal.default_model()
    red = identify(B, A, _vre(model, TILTED), U, direction=TILTED)
    est = red.estimate
    assert est.label("K2") == "K2+0.0001*Koo+0.01*Kio"
    assert next(r["coefficient"] for r in red.rows()) == "K2+0.0001*Koo+0.01*Kio"
    for name in est.names:
        want = true_value(model, est.label(name))
        assert abs(est[name] - want) <= 1e-6 * abs(want) + 1e-3 * est.std_of(name), name
    # K2 alone would be off by 0.01 Kio = -0.22 ug/g^2, twenty stated SDs
    assert abs(est["K2"] - model.K2) > 10 * est.std_of("K2")
    assert {a.term for a in red.aliases} == {"K4"}  # separable, no default prior (K4 = 0)


def test_separable_terms_are_bounded_by_their_default_priors():
    model = accelcal.default_model()
    y = _vre(model, TWO)
    red = identify(B, A, y, U, direction=TWO)
    bare = identify(B, A, y, U, direction=TWO, priors="none")
    assert {p.name for p in red.priors} == {"Koo", "Kpp", "Kio", "Kip", "Kop"}
    assert all(p.source == "default" and p.distribution == "rectangular" for p in red.priors)
    assert red.priors[2].value == pytest.approx(2 * abs(model.Kio))
    for name in red.estimate.names:
        got, std = red.estimate[name], red.estimate.std_of(name)
        assert abs(got - getattr(model, name)) <= std, name  # within one stated SD
        # without the priors the same value is tens of stated SDs off
        assert abs(got - getattr(model, name)) > 20 * bare.estimate.std_of(name), name
        type_b = sum(c.contribution**2 for c in red.type_b if c.row == name)
        assert std**2 == pytest.approx(bare.estimate.std_of(name) ** 2 + type_b, rel=1e-9)
    assert any("bounded by priors" in n for n in red.estimate.notes)
    assert bare.type_b == ()
    assert bare.priors == ()


def test_aliases_are_the_rows_moved_per_unit_of_a_term():
    model = accelcal.default_model()
    bare = identify(B, A, _vre(model, TWO), U, direction=TWO, priors="none")
    moved = identify(B, A, _vre(model.replace(Kio=model.Kio + 1e-5), TWO), U, direction=TWO,
                     priors="none")
    for a in bare.aliases:
        if a.term == "Kio":
            shift = moved.estimate[a.row] - bare.estimate[a.row]
            assert shift == pytest.approx(a.sensitivity * 1e-5, rel=1e-6)


def test_along_ia_nothing_is_left_to_bound():
    model = accelcal.default_model()
    red = identify(B, A, _vre(model, (1.0, 0.0, 0.0)), U)
    assert red.type_b == ()
    assert red.priors == ()
    assert {a.term for a in red.aliases} == {"K4"}


def test_bad_priors_are_refused():
    with pytest.raises(AccelcalError, match="priors"):
        identify(B, A, _vre(accelcal.default_model(), TWO), U, direction=TWO, priors="some")


def test_priors_given_as_numbers_are_the_users_standard_uncertainties():
    y = _vre(accelcal.default_model(), TWO)
    red = identify(B, A, y, U, direction=TWO, priors={"Kio": 1e-5, "K2": 1.0})
    assert [(p.name, p.value, p.distribution, p.source) for p in red.priors] == \
        [("Kio", 1e-5, "normal", "user")]  # K2 is fitted: its prior is not used
    with pytest.raises(AccelcalError, match="not a rectifying term"):
        identify(B, A, y, U, direction=TWO, priors={"K1": 1e-5})
    with pytest.raises(AccelcalError, match="prior of Kio"):
        identify(B, A, y, U, direction=TWO, priors={"Kio": -1.0})
