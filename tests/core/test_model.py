"""ErrorModel: each term against hand-computed values, broadcasting, validation, notations."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from accelcal import AccelcalError, ErrorModel, default_model
from accelcal.model import TERMS

# Hand-computed values: one term non-zero at a time, inputs chosen so the
# products are exact in binary floating point (powers of two), so the
# comparison is exact (==), not within a tolerance.
A_I, A_O, A_P = 0.5, 0.25, -2.0
HAND = [
    # (term, value, expected E/K1 in g at (A_I, A_O, A_P))
    ("K0", 0.125, 0.125 + A_I),
    ("K2", 2.0**-10, A_I + 2.0**-10 * A_I**2),  # 0.5 + 2^-12
    ("K3", 2.0**-10, A_I + 2.0**-10 * A_I**3),  # 0.5 + 2^-13
    ("K4", 2.0**-10, A_I + 2.0**-10 * A_I**4),  # 0.5 + 2^-14
    ("Ko", 2.0**-8, A_I + 2.0**-8 * A_O),
    ("Kp", 2.0**-8, A_I + 2.0**-8 * A_P),
    ("Koo", 2.0**-8, A_I + 2.0**-8 * A_O**2),
    ("Kpp", 2.0**-8, A_I + 2.0**-8 * A_P**2),
    ("Kio", 2.0**-8, A_I + 2.0**-8 * A_I * A_O),
    ("Kip", 2.0**-8, A_I + 2.0**-8 * A_I * A_P),
    ("Kop", 2.0**-8, A_I + 2.0**-8 * A_O * A_P),
    ("K0_asym", 2.0**-8, A_I + 0.5 * 2.0**-8),  # sgn(0.5) = +1
    ("K1_asym", 2.0**-8, A_I + 0.5 * 2.0**-8 * A_I),
]
HAND_LITERAL = {
    # The same expectations written out by hand as literals, so a mistake in
    # the expressions above cannot hide one in the model.
    "K0": 0.625, "K2": 0.500244140625, "K3": 0.5001220703125, "K4": 0.50006103515625,
    "Ko": 0.5009765625, "Kp": 0.4921875, "Koo": 0.500244140625, "Kpp": 0.515625,
    "Kio": 0.5004882812500, "Kip": 0.49609375, "Kop": 0.498046875,
    "K0_asym": 0.501953125, "K1_asym": 0.5009765625,
}


@pytest.mark.parametrize(("term", "value", "expected"), HAND)
def test_each_term_alone_matches_hand_value(term, value, expected):
    model = ErrorModel(**{term: value}, K1=4.0, output_unit="mA")
    assert model.output_g(A_I, A_O, A_P) == expected == HAND_LITERAL[term]
    assert model.output(A_I, A_O, A_P) == 4.0 * expected


def test_hand_table_covers_every_coefficient():
    assert {t for t, _, _ in HAND} == set(TERMS) - {"K1", "sigma"}


def test_ideal_model_is_identity_in_g():
    a = np.linspace(-3, 3, 13)
    np.testing.assert_array_equal(ErrorModel(output_unit="g").output_g(a, 0.3, -0.2), a)


@pytest.mark.parametrize(
    ("a_i", "expected"),
    [
        (-0.5, -0.5 - 0.5 * (2.0**-6 + 2.0**-7 * -0.5)),  # sgn = -1
        (0.0, 0.0),  # sgn(0) = 0: no asymmetry contribution at all
        (-0.0, 0.0),
        (0.5, 0.5 + 0.5 * (2.0**-6 + 2.0**-7 * 0.5)),  # sgn = +1
    ],
)
def test_asymmetry_term_sign_cases(a_i, expected):
    model = ErrorModel(K0_asym=2.0**-6, K1_asym=2.0**-7)
    assert model.output_g(a_i) == expected


def test_asymmetry_is_a_jump_at_zero():
    model = ErrorModel(K0_asym=2e-6)
    tiny = np.nextafter(0.0, 1.0)
    jump = model.output_g(tiny) - model.output_g(-tiny)
    # 1/2 K0' (sgn(+) - sgn(-)) = K0'; the a_i terms are ~5e-324.
    assert jump == pytest.approx(2e-6, rel=1e-12, abs=0)


@settings(max_examples=60, deadline=None)
@given(
    shapes=hnp.mutually_broadcastable_shapes(num_shapes=3, min_dims=0, max_dims=3, max_side=4),
    seed=st.integers(0, 2**32 - 1),
)
def test_output_broadcasts_like_numpy(shapes, seed):
    rng = np.random.default_rng(seed)
    a_i, a_o, a_p = (rng.uniform(-2, 2, size=s) for s in shapes.input_shapes)
    model = default_model()
    out = model.output(a_i, a_o, a_p)
    assert np.shape(out) == shapes.result_shape
    # Element by element against scalar evaluation.
    bi, bo, bp = np.broadcast_arrays(a_i, a_o, a_p)
    for idx in np.ndindex(shapes.result_shape):
        assert np.asarray(out)[idx] == pytest.approx(
            float(model.output(bi[idx], bo[idx], bp[idx])), rel=0, abs=0
        )


def test_output_is_scale_factor_times_output_g():
    model = default_model()
    a = np.linspace(-1, 1, 7)
    np.testing.assert_array_equal(model.output(a, 0.1), model.K1 * model.output_g(a, 0.1))


def test_noise_only_with_rng_and_reproducible():
    model = ErrorModel(sigma=1e-3)
    a = np.zeros(20000)
    np.testing.assert_array_equal(model.output_g(a), a)
    x1 = model.output_g(a, rng=np.random.default_rng(7))
    x2 = model.output_g(a, rng=np.random.default_rng(7))
    np.testing.assert_array_equal(x1, x2)
    # Sample SD of 20000 normals: relative standard error 1/sqrt(2 n) = 0.5 %;
    # 3 % is six standard errors.
    assert np.std(x1) == pytest.approx(1e-3, rel=0.03)
    assert abs(np.mean(x1)) < 6 * 1e-3 / math.sqrt(a.size)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_input_is_refused(bad):
    with pytest.raises(AccelcalError, match="a_o has non-finite"):
        ErrorModel().output(1.0, [0.0, bad])


@pytest.mark.parametrize("term", list(TERMS))
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_coefficient_names_the_term(term, bad):
    with pytest.raises(AccelcalError, match=rf"term {term} = .* is not finite"):
        ErrorModel(**{term: bad})


@pytest.mark.parametrize("bad", ["1e-6", None, True, [1.0], 1j])
def test_non_number_coefficient_names_the_term(bad):
    with pytest.raises(AccelcalError, match="term K2 must be a real number"):
        ErrorModel(K2=bad)


def test_zero_scale_factor_is_refused():
    with pytest.raises(AccelcalError, match=r"K1 \(scale factor\) is 0"):
        ErrorModel(K1=0.0)


def test_negative_sigma_and_bad_unit_are_refused():
    with pytest.raises(AccelcalError, match="sigma"):
        ErrorModel(sigma=-1e-6)
    with pytest.raises(AccelcalError, match="output_unit 'uV'"):
        ErrorModel(output_unit="uV")


def test_unknown_term_is_refused_with_suggestion():
    with pytest.raises(AccelcalError, match=r"unknown term 'k2' \(did you mean K2"):
        ErrorModel.from_terms({"k2": 1e-6})
    with pytest.raises(AccelcalError, match=r"unknown term 'Kxx'.*valid terms are: K0, K1"):
        default_model().replace(Kxx=1.0)


def test_replace_keeps_other_terms_and_validates():
    base = default_model()
    changed = base.replace(K2=1e-5)
    assert changed.K2 == 1e-5
    assert {k: v for k, v in changed.terms().items() if k != "K2"} == {
        k: v for k, v in base.terms().items() if k != "K2"
    }
    with pytest.raises(AccelcalError):
        base.replace(K1=0.0)


def test_model_is_frozen():
    with pytest.raises(AttributeError):
        default_model().K0 = 1.0  # type: ignore[misc]


def test_units_follow_output_unit():
    units = ErrorModel(output_unit="mV").units()
    assert units["K1"] == "mV/g"
    assert units["K0"] == "g"
    assert units["K2"] == "g/g^2"
    assert units["K1_asym"] == "g/g"


finite = st.floats(-1e-2, 1e-2, allow_nan=False, allow_infinity=False)
scale = st.floats(0.1, 2000.0)


@settings(max_examples=50, deadline=None)
@given(
    k_i=scale, k_0=finite, k_ii=finite, k_iii=finite, k_o=finite, k_p=finite,
    k_oo=finite, k_pp=finite, k_op=finite, k_io=finite, k_ip=finite,
)
def test_guantang_round_trip(**coeffs):
    model = ErrorModel.from_guantang(output_unit="mV", **coeffs)
    assert model.to_guantang() == coeffs
    assert coeffs["k_i"] == model.K1
    assert model.Kop == coeffs["k_op"]
    assert model.output_unit == "mV"


@settings(max_examples=50, deadline=None)
@given(K_F=finite, K_I=scale, K_O=finite, K_IO=finite, K_II=finite)
def test_dong2014_round_trip(K_F, K_I, K_O, K_IO, K_II):
    model = ErrorModel.from_dong2014(K_F, K_I, K_O, K_IO, K_II)
    back = model.to_dong2014()
    # x / K_I * K_I differs from x by at most one rounding: 2 ulp relative.
    for name, value in {"K_F": K_F, "K_I": K_I, "K_O": K_O, "K_IO": K_IO, "K_II": K_II}.items():
        assert back[name] == pytest.approx(value, rel=4.5e-16, abs=1e-300)


def test_dong2014_model_equation_matches_paper_form():
    # Dong2014 eq. (5): U = K_F + K_I a_i + K_O a_o + K_IO a_i a_o + K_II a_i^2, volts.
    K_F, K_I, K_O, K_IO, K_II = -8.336e-4, 1.2993698, -1.226e-5, -2.849e-5, 3.91e-6
    model = ErrorModel.from_dong2014(K_F, K_I, K_O, K_IO, K_II)
    beta = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    a_i, a_o = np.sin(beta), np.cos(beta)
    paper = K_F + K_I * a_i + K_O * a_o + K_IO * a_i * a_o + K_II * a_i**2
    # Relative 1e-15 of the largest output (~1.3 V): a few roundings.
    np.testing.assert_allclose(model.output(a_i, a_o), paper, rtol=0, atol=1.3e-15 * 4)


def test_dong2014_noise_is_converted_to_g():
    assert ErrorModel.from_dong2014(0.0, 2.0, sigma=1e-6).sigma == pytest.approx(5e-7, rel=1e-15)


def test_notations_refuse_terms_they_cannot_carry():
    with pytest.raises(AccelcalError, match=r"Dong2014 eq\. \(5\) has no term for K3"):
        ErrorModel(K3=1e-7).to_dong2014()
    with pytest.raises(AccelcalError, match=r"GuanTang eq\. \(13\) has no term for K0_asym"):
        ErrorModel(K0_asym=1e-6).to_guantang()
    with pytest.raises(AccelcalError, match="unknown term 'k_x'"):
        ErrorModel.from_guantang(k_x=1.0)
    with pytest.raises(AccelcalError, match="K_I is 0"):
        ErrorModel.from_dong2014(0.0, 0.0)


def test_default_model_matches_its_documented_sources():
    m = default_model()
    # Dong2014 Table 1, sensor 1 (volts) and Guan2021 Table 1.
    dong = {"K_F": -8.336e-4, "K_I": 1.2993698, "K_O": -1.226e-5, "K_IO": -2.849e-5}
    assert pytest.approx(dong["K_F"], rel=1e-15) == m.K1 * m.K0
    assert dong["K_I"] == m.K1
    assert m.K1 * m.Ko == pytest.approx(dong["K_O"], rel=1e-15)
    assert m.K1 * m.Kio == pytest.approx(dong["K_IO"], rel=1e-15)
    assert (m.K2, m.K3, m.K0_asym, m.K1_asym) == (7.87e-6, 1.19e-7, 2.26e-6, 1.45e-6)
