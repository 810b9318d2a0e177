"""The triad calibrations under the reduction contract (issue 12).

Random triads (raw counts with offsets of hundreds of counts, or m/s^2)
are turned through static positions by the rig (:mod:`accelcal.rigs.triad`,
a full time series with motions), the static intervals' means taken over
the rig's known sample ranges, and calibrated by both routes:

- known orientations, the six Ferraris positions (dof 6);
- known orientations, 18 positions (six + 12 random), sample-count weights;
- gravity norm, 30 random orientations (dof 21);
- gravity norm with quadratic terms, 40 random orientations;
- every term non-zero: each axis a pendulous accelerometer whose terms the triad model
  leaves out (K2, K3, Koo, Kpp, Kio, Kip, Kop, K0', K1'), bounded by the default priors
  as Type B (:func:`with_type_b`): known orientations (18, with each position tilted by
  0.1 mrad and the tilt stated, as ``triad calibrate --fixture-tilt`` runs it) and the
  gravity norm (30).

The coverage harness (tests/helpers/coverage.py) runs every class here.
"""

import dataclasses

import numpy as np

import accelcal
from accelcal.methods.triad import (
    PARAMS,
    QUADRATIC,
    TriadCalibration,
    calibrate_known,
    calibrate_unknown,
)
from accelcal.methods.triad.unestimated import TERMS, with_type_b
from accelcal.rigs.triad import random_directions, simulate, six_positions
from helpers.contract import ReductionContract, spread_terms

G = 9.80665


class _TriadContract(ReductionContract):
    UNIT = "counts"
    NOISE = 4.0  # per sample, input unit (counts: a 16-bit triad's few-count noise)
    QUADRATIC = False
    KNOWN = True
    DEFAULT_K = 2.0
    """The default accelerometer's case: every axis's terms at one sign (K2, Koo and Kpp all
    move a bias the same way) add linearly against their independent priors: up to 1.7
    stated SDs (docs/triad.md)."""

    def reduce_means(self, data, means, counts):  # pragma: no cover - supplied by subclasses
        raise NotImplementedError

    def reduce(self, data):
        # a record whose axes the rig simulated as pendulous accelerometers: their terms are
        # bounded as Type B (accelcal.methods.triad.unestimated)
        means, counts = data.interval_means()
        red = self.reduce_means(data, means, counts)
        if data.metadata.get("axis_models"):
            red = with_type_b(red, means, lambda m: self.reduce_means(data, m, counts),
                              gravity=G, up=data.up if self.KNOWN else None,
                              labels=data.labels)
        return red

    def default_case(self):
        # every axis the embedded default accelerometer (all its terms non-zero), noise-free
        if self.QUADRATIC:
            return None
        rng = np.random.default_rng(7)
        truth = self.truth(rng)
        data = simulate(truth, self.directions(rng), rate=50.0, dwell=2.0, motion=1.0,
                        still=4.0, noise_sd=0.0, seed=rng, gravity=G, axis_models="default")
        return data, self.expected(truth)

    def directions(self, rng):
        return random_directions(30, rng)

    def truth(self, rng):
        if self.UNIT == "counts":
            bias, scale = rng.uniform(-500, 500, 3), rng.uniform(5.8e-4, 6.2e-4, 3)
        else:
            bias, scale = rng.uniform(-0.2, 0.2, 3), rng.uniform(0.97, 1.03, 3)
        q = rng.uniform(-2e-4, 2e-4, 3) if self.QUADRATIC else None
        return TriadCalibration(bias, scale, rng.uniform(-3e-3, 3e-3, 3), q, self.UNIT)

    def simulate(self, truth, rng, noisy):
        return simulate(truth, self.directions(rng), rate=50.0, dwell=2.0, motion=1.0,
                        still=4.0, noise_sd=self.NOISE if noisy else 0.0, seed=rng, gravity=G)

    def expected(self, truth):
        names = PARAMS + (QUADRATIC if self.QUADRATIC else ())
        return [dict(zip(names, truth.vector.tolist(), strict=True))]

    def noise_free_tolerance(self, name, value):
        # Noise-free readings carry their rounding (1e-16 relative, ~2e-12 counts at 1.6e4
        # counts); the fits' conditioning (< 20) and the LM's convergence (xtol 1e-15) keep
        # the estimates within 1e-9 relative; angles (~1e-3 rad) and q get 1e-12 absolute.
        return 1e-9 * abs(value) + 1e-12


class TestContractKnownSix(_TriadContract):
    def directions(self, rng):
        return six_positions()

    def reduce_means(self, data, means, counts):
        # The first interval (still period + dwell) holds 3x the samples: weights by counts
        return calibrate_known(means, data.up, G, input_unit=data.input_unit, counts=counts)


class TestContractKnownEighteen(_TriadContract):
    UNIT = "m/s^2"
    NOISE = 5e-3

    def directions(self, rng):
        return np.vstack([six_positions(), random_directions(12, rng)])

    def reduce_means(self, data, means, counts):
        return calibrate_known(means, data.up, G, input_unit=data.input_unit, counts=counts,
                               labels=data.labels)


class TestContractGravityNorm(_TriadContract):
    KNOWN = False

    def reduce_means(self, data, means, counts):
        return calibrate_unknown(means, G, input_unit=data.input_unit, counts=counts)


class TestContractGravityNormQuadratic(_TriadContract):
    QUADRATIC = True

    def directions(self, rng):
        return random_directions(40, rng)

    KNOWN = False

    def reduce_means(self, data, means, counts):
        return calibrate_unknown(means, G, input_unit=data.input_unit, counts=counts,
                                 quadratic=True)


def test_contract_reductions_carry_their_fields():
    rng = np.random.default_rng(3)
    t = TestContractKnownEighteen()
    truth = t.truth(rng)
    red = t.reduce(t.simulate(truth, rng, noisy=True))
    assert red.assumed("noise") == "residuals"
    assert red.assumed("weights") == "counts"
    assert red.assumed("gravity") == G
    assert red.dof == 3 * 18 - 12
    assert red.identifiability.full_rank
    assert red.identifiability.condition_number < 20
    assert set(red.observations) >= {"means", "means_sd", "norm_before", "norm_after", "up",
                                     "rotation"}
    assert red.provenance["labels"][:6] == ["P1", "P2", "P3", "P4", "P5", "P6"]
    u = TestContractGravityNorm()
    red = u.reduce(u.simulate(u.truth(rng), rng, noisy=True))
    assert red.dof == 30 - 9
    assert np.isnan(red.observations["norm_before"]).all()
    assert np.sqrt(np.mean(red.observations["norm_after"] ** 2)) < 1e-3


# ------------------------------------------------------------------ every term non-zero
@dataclasses.dataclass(frozen=True)
class EveryTermTruth:
    """A triad whose axes are pendulous accelerometers, every term non-zero."""

    calibration: TriadCalibration
    models: tuple
    tilt: np.ndarray | None = None

    @property
    def vector(self):
        return self.calibration.vector


def tilted(up, sd, rng):
    """``up`` each turned by a random small rotation, SD ``sd`` rad about each axis."""
    if not sd:
        return up
    turn = sd * rng.standard_normal(up.shape)
    out = up + np.cross(turn, up)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def as_nominal(data, nominal):
    """``data`` whose positions state the nominal orientations (what the fixture's drawing
    says), not the tilted ones the rig turned it to."""
    positions = [{**p, "up": v.tolist()} for p, v in zip(data.positions, nominal, strict=True)]
    return dataclasses.replace(data, positions=positions)


class _EveryTermContract(_TriadContract):
    """Every axis a pendulous accelerometer, every term non-zero, bounded by the priors.

    Each axis's K2, K3, Koo, Kpp, Kio, Kip, Kop, K0', K1' at the default
    accelerometer's magnitude times a factor log-uniform within 1/2-2, random signs
    (:func:`helpers.contract.spread_terms`: three axes are three sensors of one type);
    ``terms = default_terms`` draws them at exactly the default magnitude. K4 stays zero,
    as the default accelerometer's (it has no prior); the triad rig models no temperature.
    """

    TYPE_B = True
    terms = staticmethod(spread_terms)
    TILT = 0.0
    """SD of each known position's orientation error about each horizontal axis, rad."""

    def truth(self, rng):
        model = accelcal.default_model()
        models = tuple(dataclasses.replace(model, **self.terms(model, rng, TERMS))
                       for _ in range(3))
        return EveryTermTruth(super().truth(rng), models)

    def simulate(self, truth, rng, noisy):
        nominal = self.directions(rng)
        actual = tilted(nominal, self.TILT, rng)
        data = simulate(truth.calibration, actual, rate=50.0, dwell=2.0, motion=1.0, still=4.0,
                        noise_sd=self.NOISE if noisy else 0.0, seed=rng, gravity=G,
                        axis_models=truth.models)
        return as_nominal(data, nominal)

    def default_case(self):
        rng = np.random.default_rng(7)
        truth = self.truth(rng)
        model = accelcal.default_model()
        truth = dataclasses.replace(truth, models=(model,) * 3)
        return self.simulate(truth, rng, noisy=False), self.expected(truth)


class TestContractEveryTermKnown(_EveryTermContract):
    UNIT = "m/s^2"
    NOISE = 5e-3
    TILT = 1e-4

    def directions(self, rng):
        return np.vstack([six_positions(), random_directions(12, rng)])

    def reduce_means(self, data, means, counts):
        # as `triad calibrate --fixture-tilt` runs it: gls, the intervals' own noise
        sd = np.array([data.acc[p["start"]:p["stop"]].std(axis=0, ddof=1)
                       for p in data.positions]) / np.sqrt(counts)[:, None]
        return calibrate_known(means, data.up, G, input_unit=data.input_unit, counts=counts,
                               labels=data.labels, noise_sd=np.maximum(sd, 1e-12),
                               fixture_tilt=self.TILT)


class TestContractEveryTermGravityNorm(_EveryTermContract):
    KNOWN = False

    def reduce_means(self, data, means, counts):
        return calibrate_unknown(means, G, input_unit=data.input_unit, counts=counts)
