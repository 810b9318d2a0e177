"""The acceptance reductions under the reduction contract (tests/helpers/contract.py).

Threshold, resolution: a random scale factor, bias and stick-slip break-away
level -> the indexing-head rig (:mod:`accelcal.rigs.acceptance`) ->
:func:`accelcal.methods.acceptance.reduce_steps` -> the increment the 50 %
rule decides and the response to every increment (1 for a step beyond the
break-away level, 0 below it). Hysteresis: a random Duhem hysteresis ->
the cycle 0 -> +1 g -> 0 -> -1 g -> 0 -> :func:`reduce_hysteresis` -> the
decreasing-minus-increasing sensed input at every point. Magnetic: a random
sensitivity vector -> Helmholtz coils -> :func:`reduce_magnetic` -> m.
"""

import numpy as np

from accelcal.methods.acceptance import reduce_hysteresis, reduce_magnetic, reduce_steps
from accelcal.rigs.acceptance import LADDER_ARCSEC, programme, sensed, simulate
from accelcal.rigs.acceptance_env import simulate_magnetic
from helpers.contract import ReductionContract

NOISE = 5e-6
"""Output noise per sample, g of input (times K1 in the output)."""


def _setup(rng):
    return {"K1": rng.uniform(0.5, 3.0) * rng.choice([-1.0, 1.0]),
            "K0": rng.uniform(-2e-3, 2e-3)}


class TestThresholdContract(ReductionContract):
    TEST = "threshold"
    SET_POINT = 0.0
    FRICTION = 2e-5

    def truth(self, rng):
        return _setup(rng) | {"breakaway": rng.uniform(3e-6, 40e-6)}

    def simulate(self, truth, rng, noisy):
        return simulate(self.TEST, scale_factor=truth["K1"], bias=truth["K0"],
                        set_point=self.SET_POINT, breakaway=truth["breakaway"],
                        friction=self.FRICTION,
                        noise=NOISE * abs(truth["K1"]) if noisy else 0.0, seed=rng)

    def reduce(self, data):
        return reduce_steps(data)

    def expected(self, truth):
        a0 = np.sin(np.radians(self.SET_POINT))
        steps = np.abs(np.sin(np.radians(self.SET_POINT + np.asarray(LADDER_ARCSEC) / 3600.0))
                       - a0)
        moves = steps > truth["breakaway"] + self.FRICTION * abs(a0)
        out = {self.TEST: float(steps[np.argmax(moves)])}
        return [out | {f"response_{k + 1}": float(m) for k, m in enumerate(moves)}]

    def noise_free_tolerance(self, name, value):
        # A response divides a difference of outputs near |K0 + K1 a0| <= 3 (rounding 1e-15)
        # by a predicted change >= 0.5 * 2.4e-6: 1e-9 with margin.
        return 1e-9 * (1.0 + abs(value))


class TestResolutionContract(TestThresholdContract):
    TEST = "resolution"
    SET_POINT = 30.0


class TestHysteresisContract(ReductionContract):
    def truth(self, rng):
        return _setup(rng) | {"hysteresis": rng.uniform(5e-6, 50e-6),
                              "span": rng.uniform(0.02, 0.2)}

    def simulate(self, truth, rng, noisy):
        return simulate("hysteresis", scale_factor=truth["K1"], bias=truth["K0"],
                        hysteresis=truth["hysteresis"], hysteresis_span=truth["span"],
                        noise=NOISE * abs(truth["K1"]) if noisy else 0.0, seed=rng)

    def reduce(self, data):
        return reduce_hysteresis(data)

    def expected(self, truth):
        applied = np.sin(np.radians(programme("hysteresis")))
        x = sensed(applied, breakaway=10e-6, friction=2e-5, set_point_g=0.0,
                   hysteresis=truth["hysteresis"], hysteresis_span=truth["span"])
        direction = np.r_[0.0, np.sign(np.diff(applied))]
        out, k = {}, 0
        for a in np.unique(applied):
            up, down = (applied == a) & (direction > 0), (applied == a) & (direction < 0)
            if up.any() and down.any():
                k += 1
                out[f"hysteresis_{k}"] = float(x[down].mean() - x[up].mean())
        return [out]

    def noise_free_tolerance(self, name, value):
        # Output differences near |K0 + K1| <= 3 (rounding ~1e-15) over K1 >= 0.5.
        return 1e-13


class TestMagneticContract(ReductionContract):
    """A random sensitivity vector in Helmholtz coils -> :func:`reduce_magnetic` -> m."""

    def truth(self, rng):
        return _setup(rng) | {"m": rng.uniform(-50e-6, 50e-6, 3)}

    def simulate(self, truth, rng, noisy):
        return simulate_magnetic(truth["m"], scale_factor=truth["K1"], bias=truth["K0"],
                                 dwell=2.0, noise=NOISE if noisy else 0.0, seed=rng)

    def reduce(self, data):
        return reduce_magnetic(data)

    def expected(self, truth):
        return [dict(zip(("m_x", "m_y", "m_z"), map(float, truth["m"]), strict=True))]

    def noise_free_tolerance(self, name, value):
        # Dwell means near |K1 K0| <= 6e-3 (rounding ~1e-18) over K1 >= 0.5 and sum B^2 = 2.5.
        return 1e-12
