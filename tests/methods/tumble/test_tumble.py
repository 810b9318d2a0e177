"""Multipoint tumble (IEEE 1293 style): Fourier relations, identifiability, reduction.

Independent routes used here: the Fourier relations of DOMAIN section 5 are
checked by exact discrete Fourier sums over noiseless outputs of
``ErrorModel.output`` (the model code, not the tumble module); the design is
checked against ``ErrorModel.output``; aliasing tables are derived by hand
from trigonometric identities at the positions (stated at each test); the
covariance is checked against a vectorised Monte Carlo scatter.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from accelcal import ErrorModel
from accelcal.errors import AccelcalError
from accelcal.methods.tumble import (
    ASYMMETRY_TERMS,
    DEFAULT_TERMS,
    FULL_TERMS,
    combination_label,
    design_matrix,
    fourier_coefficients,
    identifiability,
    reduce_tumble,
    specific_force,
    tumble_arrays,
)

TWO_PI = 2.0 * np.pi

# Noise-free tolerances. Every small coefficient comes from differences of
# outputs of order K1 * 1 g; double rounding of those (eps ~ 2.2e-16, N <= 24
# terms, factors up to 8 in the Fourier relations) leaves an absolute floor of
# a few 1e-15 g/g^n. ABS = 1e-13 is ~50x that floor; REL = 1e-12 bounds the
# relative error of K1 and of large terms.
REL, ABS = 1e-12, 1e-13


def uniform(n, start=0.0):
    return start + np.arange(n) * TWO_PI / n


def inputs(theta, axis):
    """(a_i, a_o, a_p) computed here, independently of the tumble module."""
    c, s = np.cos(theta), np.sin(theta)
    c = np.where(np.abs(c) < 1e-15, 0.0, c)
    s = np.where(np.abs(s) < 1e-15, 0.0, s)
    z = np.zeros_like(theta)
    return (c, z, s) if axis == "OA" else (s, c, z)


coef = st.floats(-2e-3, 2e-3, allow_nan=False)
scale = st.floats(0.5, 3.0).flatmap(lambda v: st.sampled_from([v, -v]))


def model_strategy(axis, *, cross_nl=True, asym=False):
    names = FULL_TERMS[axis] if cross_nl else DEFAULT_TERMS[axis]
    extra = ASYMMETRY_TERMS if asym else ()
    small = [t for t in (*names, *extra) if t != "K1"]
    return st.builds(
        lambda k1, vals: ErrorModel(K1=k1, **dict(zip(small, vals, strict=True))),
        scale,
        st.tuples(*[coef] * len(small)),
    )


def close(est, true):
    return abs(est - true) <= REL * abs(true) + ABS


# ------------------------------------------------------- Fourier relations
@settings(max_examples=25, deadline=None)
@given(model_strategy("OA"), st.sampled_from([12, 24, 36]))
def test_domain_fourier_relations_oa_by_exact_discrete_sums(m, n):
    """DOMAIN section 5 relations, every one, with Kpp and K4 present."""
    theta = uniform(n, 0.1)  # any start angle: the relations do not depend on it
    E = m.output(*inputs(theta, "OA"))
    A = {k: 2.0 / n * np.sum(E * np.cos(k * theta)) for k in range(1, 5)}
    B = {k: 2.0 / n * np.sum(E * np.sin(k * theta)) for k in range(1, 5)}
    A0 = np.mean(E)
    K1 = m.K1
    tol = 1e-14 * abs(K1)  # exact identities up to rounding of sums of ~1 g outputs
    assert abs(A[1] - K1 * (1 + 3 * m.K3 / 4)) < tol
    assert abs(B[1] - K1 * m.Kp) < tol  # IEEE delta_o is accelcal's +Kp
    assert abs(2 * A[2] / K1 - (m.K2 - m.Kpp + m.K4)) < tol
    assert abs(2 * B[2] / K1 - m.Kip) < tol
    assert abs(4 * A[3] / K1 - m.K3) < tol
    assert abs(8 * A[4] / K1 - m.K4) < tol
    assert abs(A0 / K1 - (m.K0 + (m.K2 + m.Kpp) / 2 + 3 * m.K4 / 8)) < tol
    assert abs(B[3]) < tol
    assert abs(B[4]) < tol
    # and the module's coefficients equal these sums
    fc = fourier_coefficients(theta, E)
    np.testing.assert_allclose(fc.A[1:], [A[k] for k in range(1, 5)], rtol=0, atol=tol)
    np.testing.assert_allclose(fc.B[1:], [B[k] for k in range(1, 5)], rtol=0, atol=tol)


@settings(max_examples=25, deadline=None)
@given(model_strategy("PA"), st.sampled_from([12, 24]))
def test_fourier_relations_pa_by_exact_discrete_sums(m, n):
    """About PA (a_i = sin, a_o = cos): derived relations, checked by sums."""
    theta = uniform(n, -0.3)
    E = m.output(*inputs(theta, "PA"))
    A = {k: 2.0 / n * np.sum(E * np.cos(k * theta)) for k in range(1, 5)}
    B = {k: 2.0 / n * np.sum(E * np.sin(k * theta)) for k in range(1, 5)}
    K1 = m.K1
    tol = 1e-14 * abs(K1)
    assert abs(B[1] - K1 * (1 + 3 * m.K3 / 4)) < tol
    assert abs(A[1] - K1 * m.Ko) < tol
    assert abs(-2 * A[2] / K1 - (m.K2 - m.Koo + m.K4)) < tol
    assert abs(2 * B[2] / K1 - m.Kio) < tol
    assert abs(-4 * B[3] / K1 - m.K3) < tol
    assert abs(8 * A[4] / K1 - m.K4) < tol
    assert abs(np.mean(E) / K1 - (m.K0 + (m.K2 + m.Koo) / 2 + 3 * m.K4 / 8)) < tol


def test_nyquist_harmonic_of_eight_points_has_unit_weight():
    """At N = 8, cos(4 theta) = (-1)^j: its amplitude is (1/N) sum, so 8 A4/K1 = K4."""
    m = ErrorModel(K1=1.5, K4=7e-4, K2=1e-3)
    theta = uniform(8)
    fc = fourier_coefficients(theta, m.output(*inputs(theta, "OA")))
    assert fc.k == (0, 1, 2, 3, 4)
    assert abs(8 * fc.A[4] / m.K1 - m.K4) < 1e-15
    assert fc.B[4] == 0.0


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(["OA", "PA"]), st.data())
def test_design_matches_the_error_model(axis, data):
    m = data.draw(model_strategy(axis, asym=True))
    theta = np.concatenate([uniform(24), [0.123, 2.5]])
    terms = (*FULL_TERMS[axis], *ASYMMETRY_TERMS)
    b = np.array([m.K1 if t == "K1" else m.K1 * getattr(m, t) for t in terms])
    D = design_matrix(theta, axis, terms)
    np.testing.assert_allclose(
        D @ b, m.output(*inputs(theta, axis)), rtol=0, atol=1e-14 * abs(m.K1)
    )


def test_specific_force_is_exactly_zero_where_the_input_axis_is_horizontal():
    a_i, a_o, a_p = specific_force(uniform(4), "OA")
    assert a_i.tolist() == [1.0, 0.0, -1.0, 0.0]
    assert a_p.tolist() == [0.0, 1.0, 0.0, -1.0]
    a_i, a_o, _ = specific_force(uniform(4), "PA")
    assert a_i.tolist() == [0.0, 1.0, 0.0, -1.0]
    assert a_o.tolist() == [1.0, 0.0, -1.0, 0.0]


# --------------------------------------------------------- identifiability
CROSS = {"OA": ("Kp", "Kpp", "Kip"), "PA": ("Ko", "Koo", "Kio")}


@pytest.mark.parametrize("axis", ["OA", "PA"])
def test_four_points(axis):
    """4 points: c^3 = c and c^4 = c^2 there, c s = 0, c^2 + s^2 = 1 (hand-derived)."""
    cross, cross_nl, coupling = CROSS[axis]
    r = identifiability(uniform(4), axis)
    assert r.rank == 4
    assert not r.full_rank
    assert r.condition_number == np.inf
    assert r.identifiable == (cross,)
    assert r.unobservable == (coupling,)
    assert {frozenset(g) for g in r.aliased} == {
        frozenset({"K1", "K3"}),
        frozenset({"K0", "K2", "K4", cross_nl}),
    }
    labels = set(r.labels())
    assert labels == {"K1*(1 + K3)", f"K1*(K0 + {cross_nl})", f"K1*(K2 + K4 - {cross_nl})"}
    assert r.suggested_terms == ("K0", "K1", "K2", cross)
    assert "aliased with K3" in r.status("K1")


@pytest.mark.parametrize("axis", ["OA", "PA"])
@pytest.mark.parametrize("n", [8, 12, 24])
def test_eight_twelve_twenty_four_points(axis, n):
    """Harmonics 0..4 are distinct at N >= 8 (4 is the Nyquist one at N = 8):
    every term but the cross nonlinearity is separated; that one always
    aliases with K0 and K2 (a_i^2 + a_cross^2 = 1)."""
    cross, cross_nl, coupling = CROSS[axis]
    r = identifiability(uniform(n), axis)
    assert r.rank == 7
    assert set(r.identifiable) == {"K1", "K3", "K4", cross, coupling}
    assert r.unobservable == ()
    assert r.aliased == (("K0", "K2", cross_nl),)
    assert set(r.labels()) == {f"K1*(K0 + {cross_nl})", f"K1*(K2 - {cross_nl})"}
    # The default reduction terms are then fully identifiable.
    d = identifiability(uniform(n), axis, terms=DEFAULT_TERMS[axis])
    assert d.full_rank
    assert d.identifiable == DEFAULT_TERMS[axis]
    # Condition number (of the column-equilibrated design, accelcal.identifiability)
    # checked through the eigenvalues of D'D.
    D = design_matrix(uniform(n), axis, DEFAULT_TERMS[axis])
    D = D / np.linalg.norm(D, axis=0)
    ev = np.linalg.eigvalsh(D.T @ D)
    assert d.condition_number == pytest.approx(np.sqrt(ev[-1] / ev[0]), rel=1e-9)


@pytest.mark.parametrize("axis", ["OA", "PA"])
def test_eight_points_lose_k4_when_the_start_angle_kills_the_nyquist_cosine(axis):
    """At N = 8, cos(4 theta_j) = cos(4 theta_0) (-1)^j: zero for theta_0 = 22.5 deg;
    then a_i^4 = 3/8 + cos(2 theta)/2 = a_i^2 - 1/8 at the positions (hand-derived)."""
    r = identifiability(uniform(8, np.pi / 8), axis, terms=DEFAULT_TERMS[axis])
    assert r.rank == 6
    assert r.aliased == (("K0", "K2", "K4"),)
    assert set(r.labels()) == {"K1*(K0 - 0.125*K4)", "K1*(K2 + K4)"}
    m = ErrorModel(K0=1e-4, K1=1.2, K4=3e-4, K3=2e-4)
    theta = uniform(8, 1.0)  # cos(4) = -0.65: separable, amplitude weighted by cos^2
    res = reduce_tumble(theta, m.output(*inputs(theta, axis)), rotation_axis=axis, sigma=1e-6)
    assert res.method == "tumble/fourier"
    assert close(res.estimate["K4"], m.K4)
    assert close(res.estimate["K0"], m.K0)
    assert close(res.estimate["K3"], m.K3)


def test_uniform_condition_number_does_not_depend_on_n_above_nyquist():
    """For N >= 9 the harmonic columns are orthogonal with norms sqrt(N) and
    sqrt(N/2): the conditioning is that of the fixed coefficient map."""
    c12 = identifiability(uniform(12), "OA", terms=DEFAULT_TERMS["OA"]).condition_number
    c24 = identifiability(uniform(24), "OA", terms=DEFAULT_TERMS["OA"]).condition_number
    c8 = identifiability(uniform(8), "OA", terms=DEFAULT_TERMS["OA"]).condition_number
    assert c12 == pytest.approx(c24, rel=1e-12)
    assert c8 < c12  # the Nyquist column of N = 8 has the larger weight 1 (not 1/2)


def test_asymmetry_separable_at_24_points_but_not_at_4():
    terms = (*DEFAULT_TERMS["OA"], *ASYMMETRY_TERMS)
    r24 = identifiability(uniform(24), "OA", terms=terms)
    assert r24.full_rank
    assert np.isfinite(r24.condition_number)
    # At 4 points sgn(cos) = cos and |cos| = cos^2: K0' aliases with K1, K1' with K2.
    r4 = identifiability(uniform(4), "OA", terms=("K0", "K1", "K2", "Kp", *ASYMMETRY_TERMS))
    assert r4.identifiable == ("K0", "Kp")
    assert {frozenset(g) for g in r4.aliased} == {
        frozenset({"K1", "K0_asym"}),
        frozenset({"K2", "K1_asym"}),
    }
    assert set(r4.labels()) == {"K1*(1 + 0.5*K0_asym)", "K1*(K2 + 0.5*K1_asym)"}


# --------------------------------------------------------------- reduction
def truth_vector(m, terms):
    return np.array([getattr(m, t) for t in terms])


@settings(max_examples=20, deadline=None)
@given(
    st.sampled_from(["OA", "PA"]),
    st.sampled_from([8, 12, 24]),
    st.sampled_from(["auto", "lsq"]),
    st.data(),
)
def test_noise_free_recovery_of_every_identifiable_term(axis, n, route, data):
    m = data.draw(model_strategy(axis, cross_nl=False))
    start = data.draw(st.floats(-np.pi, np.pi))
    # At N = 8 the 4th harmonic is the Nyquist one, seen through cos(4 theta_0)
    # (see test_eight_points_lose_k4_...): keep away from its zeros.
    assume(n != 8 or abs(np.cos(4 * start)) > 1e-3)
    theta = uniform(n, start)
    E = m.output(*inputs(theta, axis))
    res = reduce_tumble(theta, E, rotation_axis=axis, route=route, sigma=1e-6, asymmetry=False)
    assert res.method == ("tumble/fourier" if route == "auto" else "tumble/lsq")
    assert res.assumed("route") == ("fourier" if route == "auto" else "lsq")
    est, true = res.estimate.values, truth_vector(m, DEFAULT_TERMS[axis])
    # Rounding is amplified by the design's conditioning (15 for N >= 9 after
    # column equilibration; up to ~1e4 for N = 8 near a zero of cos(4 theta_0)).
    cond = res.identifiability.condition_number
    assert np.all(np.abs(est - true) <= REL * np.abs(true) + ABS * cond), est - true


@settings(max_examples=15, deadline=None)
@given(st.sampled_from(["OA", "PA"]), st.data())
def test_cross_nonlinearity_goes_where_the_notes_say(axis, data):
    """With Kpp (Koo) present but not estimated, K0 -> K0 + Kpp, K2 -> K2 - Kpp."""
    m = data.draw(model_strategy(axis))
    cross_nl = CROSS[axis][1]
    theta = uniform(24)
    res = reduce_tumble(theta, m.output(*inputs(theta, axis)), rotation_axis=axis, sigma=1e-6)
    x = getattr(m, cross_nl)
    assert close(res.estimate["K0"], m.K0 + x)
    assert close(res.estimate["K2"], m.K2 - x)
    assert any(f"K0 stands for K0 + {cross_nl}" in note for note in res.estimate.notes)
    assert res.assumed("cross_nonlinearity") == cross_nl
    # With the full term set, K0, K2 and the cross nonlinearity are NaN and
    # the two identifiable combinations are estimated.
    full = reduce_tumble(
        theta,
        m.output(*inputs(theta, axis)),
        rotation_axis=axis,
        terms=FULL_TERMS[axis],
        sigma=1e-6,
    )
    for t in ("K0", "K2", cross_nl):
        assert np.isnan(full.estimate[t])
        assert np.isnan(full.estimate.std_of(t))
        assert any(note.startswith(f"{t} not identifiable") for note in full.estimate.notes)
        assert full.status(t) == "not identifiable"
    combos = {combination_label(c): c.value for c in full.combinations}
    assert abs(combos[f"K1*(K0 + {cross_nl})"] - m.K1 * (m.K0 + x)) <= ABS * abs(m.K1)
    assert abs(combos[f"K1*(K2 - {cross_nl})"] - m.K1 * (m.K2 - x)) <= ABS * abs(m.K1)
    assert close(full.estimate["K3"], m.K3)
    assert close(full.estimate["K1"], m.K1)


@pytest.mark.parametrize("axis", ["OA", "PA"])
def test_four_point_reduction(axis):
    cross = CROSS[axis][0]
    m = ErrorModel(K0=3e-4, K1=1.1, K2=-2e-4, K3=5e-5, **{cross: 1e-4})
    theta = uniform(4)
    E = m.output(*inputs(theta, axis))
    # The suggested terms are exactly determined (0 dof): sigma must be given.
    with pytest.raises(AccelcalError, match="no degrees of freedom"):
        reduce_tumble(theta, E, rotation_axis=axis, terms=("K0", "K1", "K2", cross))
    res = reduce_tumble(theta, E, rotation_axis=axis, terms=("K0", "K1", "K2", cross), sigma=1e-6)
    # K3 is taken as zero: it goes into K1 as K1 (1 + K3) (c^3 = c at 4 points)
    assert close(res.estimate["K1"], m.K1 * (1 + m.K3))
    # b_t = K1 K_t are exact, so K_t comes out divided by (1 + K3)
    assert close(res.estimate["K2"], m.K2 / (1 + m.K3))
    assert close(res.estimate["K0"], m.K0 / (1 + m.K3))
    # Asking for K3 too: K1 and K3 are NaN, their combination is estimated.
    res = reduce_tumble(theta, E, rotation_axis=axis, terms=("K0", "K1", "K3", cross), sigma=1e-6)
    assert np.isnan(res.estimate.values[1])
    assert np.isnan(res.estimate.values[2])
    assert np.isnan(res.estimate.values).all()  # no K1, so nothing in g/g^n
    assert res.models == (None,)
    (combo,) = res.combinations
    assert combination_label(combo) == "K1*(1 + K3)"
    assert combo.label == "K1 + K1*K3"  # weights on the output-unit coefficients
    assert abs(combo.value - m.K1 * (1 + m.K3)) < ABS
    # The default (7-term) model is more unknowns than positions.
    with pytest.raises(
        AccelcalError, match=r"4 positions cannot determine 7 unknowns.*K0', 'K1', 'K2'"
    ):
        reduce_tumble(theta, E, rotation_axis=axis)


def test_fourier_and_least_squares_routes_agree():
    rng = np.random.default_rng(7)
    m = ErrorModel(K0=2e-4, K1=-1.3, K2=3e-5, K3=-4e-6, K4=2e-6, Ko=1e-4, Kio=-5e-5)
    theta = uniform(24, 0.2)
    E = m.output(*inputs(theta, "PA")) + 1e-6 * rng.standard_normal((5, 24))
    f = tumble_arrays(theta, E, rotation_axis="PA", route="fourier")
    q = tumble_arrays(theta, E, rotation_axis="PA", route="lsq")
    assert (f.route, q.route) == ("fourier", "lsq")
    # Same linear estimator by two computations: they differ by rounding of
    # ~1.3 V outputs (eps * 1.3 V * 24 terms * factors <= 8 ~ 5e-14 V, over
    # K1 = 1.3): absolute 1e-13 g/g^n, relative 1e-12.
    np.testing.assert_allclose(f.values, q.values, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(f.std, q.std, rtol=1e-9)  # s^2 from ~1e-6 V residuals
    corr = [r.covariance / (r.std[..., :, None] * r.std[..., None, :]) for r in (f, q)]
    np.testing.assert_allclose(corr[0], corr[1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(f.residuals, q.residuals, rtol=0, atol=1e-14)  # V, as above
    assert f.dof == q.dof == 17


@settings(max_examples=15, deadline=None)
@given(st.sampled_from(["OA", "PA"]), st.data())
def test_non_uniform_positions_with_asymmetry(axis, data):
    m = data.draw(model_strategy(axis, cross_nl=False, asym=True))
    theta = np.sort(data.draw(st.lists(st.floats(0, TWO_PI - 0.01), min_size=14, max_size=14)))
    gaps = np.diff(np.append(theta, theta[0] + TWO_PI))
    if gaps.min() < 0.05:  # keep positions distinct enough for a usable design
        theta = uniform(14, 0.05) + 0.02 * np.sin(np.arange(14))
    terms = (*DEFAULT_TERMS[axis], *ASYMMETRY_TERMS)
    res = reduce_tumble(
        theta, m.output(*inputs(theta, axis)), rotation_axis=axis, terms=terms, sigma=1e-6
    )
    assert res.method == "tumble/lsq"
    assert "fourier_A" not in res.observations  # no Fourier coefficients: not uniform
    rep = res.identifiability
    assert rep.full_rank
    # Noise-free recovery, allowing for the design's conditioning.
    tol = ABS * max(1.0, rep.condition_number)
    for t in terms:
        assert abs(res.estimate[t] - getattr(m, t)) <= REL * abs(getattr(m, t)) + tol


def test_dong2014_terms_about_pa():
    """The indexing-head model (Dong2014 eq. (5)) on 24 positions."""
    m = ErrorModel.from_dong2014(K_F=1e-4, K_I=1.25, K_O=2e-4, K_IO=-3e-5, K_II=4e-5)
    theta = uniform(24)
    res = reduce_tumble(
        theta,
        m.output(*inputs(theta, "PA")),
        rotation_axis="PA",
        terms=("K0", "K1", "K2", "Ko", "Kio"),
        sigma=1e-7,
    )
    assert res.method == "tumble/lsq"
    for t in ("K0", "K1", "K2", "Ko", "Kio"):
        assert close(res.estimate[t], getattr(m, t))
    assert res.estimate.units["K1"] == "V/g"
    assert res.estimate.units["Kio"] == "g/g^2"


# -------------------------------------------------------------- uncertainty
@pytest.mark.parametrize(("axis", "n", "route"), [("OA", 24, "fourier"), ("PA", 12, "lsq")])
def test_covariance_agrees_with_monte_carlo(axis, n, route):
    rng = np.random.default_rng(20261121)
    m = ErrorModel(
        K0=1e-4, K1=1.2, K2=3e-5, K3=-2e-5, K4=1e-5, **{CROSS[axis][0]: 2e-4, CROSS[axis][2]: 5e-5}
    )
    theta = uniform(n)
    trials, sd = 4000, 2e-5
    E = m.output(*inputs(theta, axis)) + sd * rng.standard_normal((trials, n))
    res = tumble_arrays(theta, E, rotation_axis=axis, route=route)
    known = reduce_tumble(theta, E[0], rotation_axis=axis, route=route, sigma=sd,
                          asymmetry=False, priors=None).estimate
    err = res.values - truth_vector(m, DEFAULT_TERMS[axis])
    # Unbiased to within 4 standard errors of the mean of 4000 trials.
    assert np.all(np.abs(err.mean(axis=0)) < 4 * known.std / np.sqrt(trials))
    # Scatter vs the covariance with the noise known: the SD of an SD from
    # 4000 normal samples is 1.1 %; 5 % is > 4 of those.
    np.testing.assert_allclose(err.std(axis=0), known.std, rtol=0.05)
    emp_corr = np.corrcoef(err.T)
    formal_corr = known.covariance / np.outer(known.std, known.std)
    np.testing.assert_allclose(emp_corr, formal_corr, rtol=0, atol=0.07)  # 4.4 SE of a correlation
    # With the noise estimated from residuals, the mean formal variance is the
    # true variance (s^2 unbiased): within 5 %.
    np.testing.assert_allclose(np.mean(res.std**2, axis=0), known.std**2, rtol=0.05)
    assert np.mean(res.sigma**2) == pytest.approx(sd**2, rel=0.05)
    # Coverage of +-2 formal SD with a t distribution of dof = n - 7.
    from scipy import stats

    expected = 2 * stats.t.cdf(2.0, res.dof) - 1
    inside = np.mean(np.abs(err) < 2 * res.std, axis=0)
    assert np.all(np.abs(inside - expected) < 0.02)  # 4 SE of a proportion of 4000


def test_repeated_readings_are_averaged():
    rng = np.random.default_rng(3)
    m = ErrorModel(K0=1e-4, K1=1.2, K2=3e-5, Kp=2e-4)
    theta = uniform(12)
    E = m.output(*inputs(theta, "OA"))[:, None] + 1e-5 * rng.standard_normal((12, 5))
    a = reduce_tumble(theta, E, repeats=True, sigma=1e-5)
    b = reduce_tumble(theta, E.mean(axis=1), sigma=1e-5 / np.sqrt(5))
    np.testing.assert_array_equal(a.estimate.values, b.estimate.values)
    np.testing.assert_allclose(a.estimate.covariance, b.estimate.covariance, rtol=1e-14)
    assert any("5 repeated readings" in note for note in a.estimate.notes)
    assert a.assumed("repeats") == 5


def test_batch_equals_trial_by_trial():
    rng = np.random.default_rng(11)
    m = ErrorModel(K0=1e-4, K1=1.2, K2=3e-5, Kp=2e-4, K3=1e-5)
    theta = uniform(12)
    E = m.output(*inputs(theta, "OA")) + 1e-6 * rng.standard_normal((2, 3, 12))
    batch = tumble_arrays(theta, E)
    assert batch.values.shape == (2, 3, 7)
    assert batch.covariance.shape == (2, 3, 7, 7)
    for idx in np.ndindex(2, 3):
        one = reduce_tumble(theta, E[idx], priors=None).estimate
        # rounding of ~1.2 V outputs summed in a different order: 1e-15 absolute
        np.testing.assert_allclose(batch.values[idx], one.values, rtol=1e-13, atol=1e-15)
        # the covariance scales with s^2 from residuals of ~1e-6 V taken out of
        # ~1 V outputs: relative rounding ~1e-16 / 1e-6 per residual -> rtol 1e-8
        np.testing.assert_allclose(batch.covariance[idx], one.covariance, rtol=1e-8, atol=0)
    with pytest.raises(AccelcalError, match="tumble_arrays"):
        reduce_tumble(theta, E)


# --------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"angles_rad": uniform(6)}, "6 positions cannot determine 7 unknowns"),
        ({"angles_rad": np.append(uniform(11), TWO_PI)}, "same angle modulo 360"),
        ({"outputs": np.full(12, np.nan)}, "NaN or infinite"),
        ({"outputs": np.ones((3, 11))}, r"shape \(\.\.\., 12\)"),
        ({"rotation_axis": "IA"}, "rotation axis 'IA'"),
        ({"terms": ("K0", "K1", "Kx")}, "'Kx' is not a model term"),
        ({"terms": ("K0", "K1", "Ko")}, "does not apply to a rotation about OA"),
        ({"terms": ("K0", "K2")}, "must include K1"),
        ({"terms": ("K0", "K1", "K0")}, "repeat"),
        (
            {"route": "fourier", "angles_rad": uniform(12) + 0.01 * np.arange(12)},
            "Fourier route needs",
        ),
        ({"route": "magic"}, "route 'magic'"),
        ({"output_unit": "furlong"}, "output_unit"),
        ({"sigma": -1.0}, "sigma"),
        ({"angles_rad": [[0.0, 1.0]]}, "1-D"),
        ({"repeats": True}, "with repeats"),
        ({"outputs": np.full(12, 0.5)}, "scale factor K1 estimated from these outputs is 0"),
    ],
)
def test_bad_input(kwargs, match):
    args = {"angles_rad": uniform(12), "outputs": np.linspace(-1, 1, 12), **kwargs}
    if "angles_rad" in kwargs and "outputs" not in kwargs:
        args["outputs"] = np.linspace(-1, 1, np.size(args["angles_rad"]))
    with pytest.raises(AccelcalError, match=match):
        reduce_tumble(args.pop("angles_rad"), args.pop("outputs"), **args)


def test_fourier_coefficients_refuse_non_uniform_positions():
    with pytest.raises(AccelcalError, match="equally spaced"):
        fourier_coefficients([0.0, 1.0, 2.0], [1.0, 2.0, 3.0])


def test_module_doctests():
    import doctest
    import importlib

    for name in ("physics.tumble", "methods.tumble.identify", "methods.tumble.fourier",
                 "methods.tumble.reduce", "methods.tumble.figures"):
        mod = importlib.import_module(f"accelcal.{name}")
        assert doctest.testmod(mod, optionflags=doctest.ELLIPSIS).failed == 0, name
    import accelcal.rigs.tumble as rig

    assert doctest.testmod(rig, optionflags=doctest.ELLIPSIS).failed == 0


# --------------------------------------------------------------------- CLI
def run_cli(args, capsys):
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main(args)
    out, err = capsys.readouterr()
    return exc.value.code, out, err


def test_cli_identify_json(capsys):
    import json

    code, out, _ = run_cli(["tumble", "identify", "--points", "4", "--format", "json"], capsys)
    assert code == 0
    doc = json.loads(out)
    assert doc["rank"] == 4
    assert doc["unknowns"] == 8
    assert doc["condition_number"] is None  # infinite: rank deficient
    status = {row["term"]: row["status"] for row in doc["terms"]}
    assert status["Kip"] == "unobservable"
    assert status["K1"] == "aliased with K3"
    assert "K1*(1 + K3)" in doc["combinations"]
    assert doc["suggested_terms"] == ["K0", "K1", "K2", "Kp"]


def test_cli_simulate_and_reduce_recover_the_true_model(tmp_path, capsys):
    import json

    path = tmp_path / "t.csv"
    args = ["tumble", "simulate", "--points", "24", "--axis", "PA", "--noise", "2e-6"]
    code, _, _ = run_cli([*args, "--repeats", "3", "--seed", "5", "--out", str(path)], capsys)
    assert code == 0
    terms = "K0,K1,K2,K3,K4,Ko,Kio,K0_asym,K1_asym"
    code, out, err = run_cli(
        ["tumble", "reduce", str(path), "--terms", terms, "--format", "json"], capsys
    )
    assert code == 0
    rows = {r["plain"]: r for r in json.loads(out)}
    assert "3 repeated readings averaged" in err
    meta = json.loads(path.read_text().splitlines()[1][2:])
    truth = meta["true_model"]
    # The default model has Koo = 4e-6: K0 and K2 carry it (K0 + Koo, K2 - Koo).
    truth = {**truth, "K0": truth["K0"] + truth["Koo"], "K2": truth["K2"] - truth["Koo"]}
    for name, row in rows.items():
        assert abs(row["estimate"] - truth[name]) < 5 * row["std"], name


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["tumble", "identify", "--points", "8", "--axis", "IA"], "rotation axis 'IA'"),
        (["tumble", "identify", "--points", "8", "--angles", "0,90"], "not both"),
        (["tumble", "identify", "--angles", "0,90,360"], "same angle modulo 360"),
        (["tumble", "identify", "--points", "8", "--terms", "K0,,K1"], "empty item"),
        (["tumble", "reduce", "missing.csv"], "not found"),
    ],
)
def test_cli_bad_input(args, match, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(args, capsys)
    assert code == 2
    assert err.startswith("accelcal: error:")
    assert match in err
    assert "Traceback" not in err


def test_cli_reduce_refuses_unequal_repeats_and_simulate_writes_nothing_on_error(tmp_path, capsys):
    from accelcal.io.records import write_record

    path = tmp_path / "r.csv"
    meta = {"units": {"angle": "deg", "output": "V"}, "rotation_axis": "OA", "output_unit": "V"}
    angle = np.array([0.0, 0.0, 90.0, 180.0, 270.0, 45.0, 135.0, 225.0, 315.0])
    write_record(path, "tumble", meta, {"angle": angle, "output": np.cos(np.radians(angle))})
    code, _, err = run_cli(["tumble", "reduce", str(path)], capsys)
    assert code == 2
    assert "different numbers of repeated readings" in err
    out = tmp_path / "never.csv"
    code, _, err = run_cli(["tumble", "simulate", "--axis", "XA", "--out", str(out)], capsys)
    assert code == 2
    assert not out.exists()
