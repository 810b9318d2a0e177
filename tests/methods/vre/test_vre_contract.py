"""The reduction contract for the VRE identification (vibrafuge records -> Reduction)."""

import time
import tracemalloc

import numpy as np
import pytest

import accelcal
from accelcal import ErrorModel
from accelcal.methods.vre import along_ia, identify, reduce_run, vector_vre
from accelcal.rigs.vibrafuge import simulate
from helpers.contract import ReductionContract, spread_terms, true_value

PAPER_B = np.repeat([1.0, 2.0, 4.0], 6)
PAPER_A = np.tile(np.arange(5.0, 11.0), 3)
"""Guan2021 Table 1 grid: b = 1, 2, 4 g and A = 5..10 g (identifies K2, K3, K0', K1')."""

PAPER_TRUTH = {"K2": 7.87e-6, "K3": 1.19e-7, "K0_asym": 2.26e-6, "K1_asym": 1.45e-6}

UNFITTED = ("K0", "Ko", "Kp", "Koo", "Kpp", "Kio", "Kip", "Kop")
"""Terms the VRE does not see: K0 cancels in the shift from the static level, and the
cross-axis terms meet no a_o, a_p with the vibration along IA."""


class TestContract(ReductionContract):
    """Random K2, K3, K0', K1' -> vibrafuge rig on the paper's grid -> reduce_run + identify."""

    def truth(self, rng):
        # navigation-grade magnitudes, random signs (about Guan2021 Table 1's); every
        # other term non-zero too, at the default accelerometer's magnitudes
        fitted = {name: value * rng.uniform(0.3, 3.0) * rng.choice([-1.0, 1.0])
                  for name, value in PAPER_TRUTH.items()}
        return ErrorModel(**fitted, K1=1.3,
                          **spread_terms(accelcal.default_model(), rng, UNFITTED))

    def simulate(self, truth, rng, noisy: bool):
        return simulate(truth, PAPER_B, PAPER_A, frequency=50.0, sample_rate=1000.0,
                        duration=0.2, phase=0.4, noise=3e-6 if noisy else 0.0, rng=rng)

    def reduce(self, data):
        meas = reduce_run(data)
        return identify(meas.overload, meas.amplitude, meas.vre, meas.uncertainty,
                        direction=meas.direction, assumptions=meas.assumptions(),
                        columns=meas.design_columns())

    def expected(self, truth):
        return [{name: getattr(truth, name) for name in PAPER_TRUTH}]

    def default_case(self):
        model = accelcal.default_model()
        return self.simulate(model, None, noisy=False), self.expected(model)

    def noise_free_tolerance(self, name: str, value: float) -> float:
        # Noise-free integrating records reduce to the closed-form VRE within
        # ~1e-15 g (tests/methods/vre/test_vre_records.py); the fit maps a VRE error e to
        # coefficient errors up to e / (smallest column sensitivity): K0' enters
        # with s0 = phi / pi >= 0.1 g/g on this grid, so 1e-13 g absolute plus
        # 1e-9 relative covers the rounding with a factor 10 to spare.
        return 1e-9 * abs(value) + 1e-13


class TestContractTilted(TestContract):
    """The vibration 10 mrad off IA towards OA: Kio and Koo rectify in proportion to
    K2, so the K2 row is ``K2+0.0001*Koo+0.01*Kio`` (named by its combination)."""

    DIRECTION = (1.0, 0.01, 0.0)

    def simulate(self, truth, rng, noisy: bool):
        return simulate(truth, PAPER_B, PAPER_A, frequency=50.0, sample_rate=1000.0,
                        duration=0.2, phase=0.4, direction=self.DIRECTION,
                        noise=3e-6 if noisy else 0.0, rng=rng)

    def row_truth(self, truth, row, value):
        return true_value(truth if isinstance(truth, ErrorModel) else accelcal.default_model(),
                          row)


def test_reduction_fields():
    """Family, method, observations and assumptions the figures and records read."""
    rng = np.random.default_rng(1)
    run = simulate(ErrorModel(**PAPER_TRUTH, K1=1.3), PAPER_B, PAPER_A, frequency=50.0,
                   sample_rate=1000.0, duration=0.2, noise=3e-6, rng=rng)
    meas = reduce_run(run)
    red = identify(meas.overload, meas.amplitude, meas.vre, meas.uncertainty,
                   assumptions=meas.assumptions())
    assert (red.family, red.method) == ("vre", "vre/identify")
    assert red.observations["overload"].shape == (18, 3)
    np.testing.assert_array_equal(red.observations["vre"], meas.vre)
    np.testing.assert_array_equal(red.observations["uncertainty"], meas.uncertainty)
    assert red.assumed("weighting") == "uncertainty"
    assert 0.2 < red.assumed("chi2_dof") < 3.0
    assert red.assumed("sampling") == "integrating"
    assert red.assumed("scale_factor") == 1.3
    assert red.identifiability.full_rank
    assert red.dof == 0  # the covariance comes from the stated uncertainties
    assert red.estimate.dof == 18 - 4
    figs = red.figures()
    assert [f[0] for f in figs] == ["vre_fit", "vre_residuals"]


def test_large_design_is_linear_in_the_number_of_points():
    """20,000 points: no n x n matrix (peak memory a few designs), done in well under a second
    of work; a rank-deficient design takes the same path through the row space."""
    n = 20_000
    rng = np.random.default_rng(3)
    b = rng.choice([1.0, 2.0, 4.0], n)
    a = rng.uniform(0.5, 10.0, n)
    model = ErrorModel(**PAPER_TRUTH)
    u = np.full(n, 1e-7)
    y = vector_vre(model, along_ia(b), a)[0] + u * rng.standard_normal(n)
    one_b = np.full(n, 2.0)
    y_one = vector_vre(model, along_ia(one_b), a)[0] + u * rng.standard_normal(n)
    identify(b[:100], a[:100], y[:100], u[:100])  # warm up imports
    tracemalloc.start()
    start = time.perf_counter()
    full = identify(b, a, y, u)
    deficient = identify(one_b, a, y_one, u)
    elapsed = time.perf_counter() - start
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    # an n x n float64 matrix would be 3.2 GB; the design itself is n * 4 * 8 = 0.64 MB
    assert peak < 100e6, peak
    assert elapsed < 10.0, elapsed
    assert full.unidentified() == ()
    assert full.value("K2") == pytest.approx(model.K2, rel=1e-3)
    assert deficient.unidentified() == ("K2", "K3")
    assert len(deficient.combinations) == 1
