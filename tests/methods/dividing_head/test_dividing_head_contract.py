"""The reduction contract (tests/helpers/contract.py) for every indexing-head reduction."""

import dataclasses
from typing import ClassVar

import numpy as np
import pytest

import accelcal
from accelcal.methods.dividing_head import HeadData, reduce
from accelcal.model import ErrorModel
from accelcal.rigs.dividing_head import AngleErrorProfile, DividingHeadRig, simulate
from accelcal.units import ARCSEC
from helpers.contract import ReductionContract, spread_terms

NOISE = 2.8e-6  # V, Dong2014 Table 1 column U


class _HeadContract(ReductionContract):
    """Four sensors at 0/90/180/270 deg, 24 positions, random Dong2014-sized coefficients,
    every other term a rotation about PA excites (K3, Koo, K0', K1') at the default
    accelerometer's magnitude times a factor within 1/2-2 with a random sign (the population
    the default priors describe: ``helpers.contract.spread_terms``), random misalignments
    (+-2 arcsec) and, where the method separates it, a random head error of harmonics 2-5
    (zero mean and first harmonic: no gauge, no alias)."""

    METHOD = ""
    OPTIONS: ClassVar[dict] = {}
    HEAD_ERROR = True
    TYPE_B = True  # K3, K0', K1' are bounded by the default priors, not estimated
    EXTRA = ("K3", "Koo", "K0_asym", "K1_asym")

    def truth(self, rng):
        models = []
        for _ in range(4):
            k_i = rng.uniform(1.2, 1.4)
            models.append(ErrorModel(
                K1=k_i, K0=rng.normal(0, 1e-3) / k_i, Ko=rng.normal(0, 1e-5) / k_i,
                Kio=rng.normal(0, 2e-5) / k_i, K2=rng.normal(0, 2e-5) / k_i,
                **spread_terms(accelcal.default_model(), rng, self.EXTRA)))
        models = tuple(models)
        terms = {(m, cs): rng.normal(0, 1.0) * ARCSEC for m in range(2, 6) for cs in "cs"}
        profile = AngleErrorProfile.harmonics(terms) if self.HEAD_ERROR else AngleErrorProfile()
        return {"models": models, "eta": rng.uniform(-2, 2, 4) * ARCSEC, "profile": profile}

    def simulate(self, truth, rng, noisy):
        rig = DividingHeadRig.uniform(24, truth["models"], eta=truth["eta"],
                                      angle_error=truth["profile"],
                                      noise=NOISE if noisy else 0.0)
        run = simulate(rig, rng if noisy else None)
        return HeadData.build(rig.positions, run.outputs, rig.mounts)

    def reduce(self, data):
        return reduce(data, self.METHOD, **self.OPTIONS)

    def expected(self, truth):
        # K_O* = K_O + K_I (eta + d0) [DOMAIN step 6]; d0 = 0 (harmonics >= 2 only); the rows
        # K_F+K_OO and K_II-K_OO (K_OO = K_I Koo) by the truth of the combination
        out = []
        for model, eta in zip(truth["models"], truth["eta"], strict=True):
            k_i = model.K1
            out.append({"K_F": k_i * (model.K0 + model.Koo), "K_I": k_i,
                        "K_O": k_i * model.Ko + k_i * eta, "K_IO": k_i * model.Kio,
                        "K_II": k_i * (model.K2 - model.Koo)})
        return out

    def test_noise_free_recovers_truth(self):
        # Every truth term lies within a factor 2 of the default magnitude a, inside its
        # prior's bound 2a (u = 2 a / sqrt 3): one term alone moves a row by at most sqrt(3) u,
        # by 1.16 u in RMS; noise-free rows are checked at k = 2 (the default case at k = 1)
        truth, red = self._run(self.SEEDS[0], noisy=False)
        for k, name, want, got, std in self._pairs(truth, red):
            tol = self.noise_free_tolerance(name, want) + 2.0 * std
            assert abs(got - want) <= tol, f"sensor {k} {name}: {got!r} vs {want!r} (tol {tol})"

    def default_case(self):
        model = accelcal.default_model()
        truth = {"models": (model,) * 4, "eta": np.zeros(4), "profile": AngleErrorProfile()}
        return self.simulate(truth, None, noisy=False), self.expected(truth)

    def test_default_accelerometer_rows_equal_their_truths(self, monkeypatch):
        # four copies of one accelerometer: their terms are equal, the setting of
        # sensor_terms="equal" (every row within 1 stated SD)
        monkeypatch.setattr(self, "OPTIONS", {**self.OPTIONS, "sensor_terms": "equal"})
        super().test_default_accelerometer_rows_equal_their_truths()

    def test_default_accelerometer_independent_terms_within_two_sd(self, monkeypatch):
        # the default takes the sensors' terms as independent, which four identical sensors
        # are not: four's and joint's K_O then err by up to 1.7 of the stated SD (measured)
        monkeypatch.setattr(self, "DEFAULT_K", 2.0)
        super().test_default_accelerometer_rows_equal_their_truths()

    def noise_free_tolerance(self, name, value):
        # Every reduction is linear in the head error and misalignment eps = |d| + |eta|
        # <= ~2e-5 rad; the neglected second-order terms are at most
        # K_I eps^2 / 2 + eps (|K_O| + |K_IO| + |K_II|) ~ 3e-10 + 2e-9 V (the bound of
        # test_dividing_head_methods._second_order_bound), times the estimators' gains (~2).
        return 5e-9 + 1e-9 * abs(value)

    def test_method_string_and_family(self):
        _, red = self._run(self.SEEDS[0], noisy=True)
        assert red.family == "dividing-head"
        assert red.method == f"dividing-head/{self.METHOD}"
        assert len(red.models) == 4
        assert all(m is not None for m in red.models)
        assert red.assumed("k_o_star") is True


class TestSingleContract(_HeadContract):
    METHOD = "single"
    HEAD_ERROR = False  # the single fit does not model the head error: it would bias it


class TestFourContract(_HeadContract):
    METHOD = "four"
    # the paper's covariance (Dong2014 eq. (31)) understates the scatter ~1.4x (documented,
    # test_dividing_head_methods.py); the propagated one is exact for the linear method
    OPTIONS: ClassVar[dict] = {"covariance": "propagated"}

    def test_shared_head_error_and_gauge(self):
        _, red = self._run(self.SEEDS[0], noisy=True)
        assert red.shared is not None
        assert red.shared.values.shape == (24,)
        assert red.covariance.shape == (44, 44)
        assert red.assumed("first_harmonic") == "zero"
        assert red.assumed("covariance") == "propagated"
        ident = red.identifiability
        assert len(ident.names) - ident.rank == 3


class TestJointContract(_HeadContract):
    METHOD = "joint"

    def test_shared_head_error_and_gauge(self):
        # without the terms Dong2014 eq. (5) leaves out (their harmonics >= 3 would enter
        # the separated head error)
        truth = self.truth(np.random.default_rng(self.SEEDS[0]))
        truth["models"] = tuple(dataclasses.replace(m, **dict.fromkeys(self.EXTRA, 0.0))
                                for m in truth["models"])
        red = self.reduce(self.simulate(truth, None, noisy=False))
        # noise-free: the separated head error is the simulated one (second order, ~1e-10 rad)
        alpha = red.observations["positions"]
        want = truth["profile"].draw(alpha, 1, None)[0]
        np.testing.assert_allclose(red.shared.values, want, rtol=0, atol=1e-9)
        assert red.covariance.shape == (44, 44)
        assert red.dof == 4 * 24 - 20 - 21
        assert len(red.identifiability.names) - red.identifiability.rank == 3


class TestTumbleOnHeadContract(_HeadContract):
    METHOD = "tumble"
    HEAD_ERROR = False

    @pytest.fixture(autouse=True)
    def _needs_tumble(self):
        tumble = pytest.importorskip("accelcal.methods.tumble")
        if not hasattr(tumble, "reduce_tumble"):
            pytest.skip("accelcal.methods.tumble.reduce_tumble not available")
