"""The transfer-function fit of a stepped-sine comparison under the reduction contract.

A random force-rebalance DUT (S0, fn, zeta) -> the comparison rig
(:mod:`accelcal.rigs.shaker_response`, 11 steps from 10 Hz to 1.25 kHz,
white noise on both channels) -> the stepped-sine reduction and the
second-order fit (:func:`accelcal.methods.response.fit_model`) -> the truth
within the stated uncertainty (tests/helpers/contract.py), the -3 dB
bandwidth's truth by brentq on the closed form written out here. The complex
points themselves, magnitude and phase, are checked in
test_response_reduce.py; the coverage harness (tests/helpers/coverage.py)
runs this class too.
"""

import numpy as np

from accelcal.methods.response import fit_model, reduce_stepped
from accelcal.rigs.shaker_response import DutResponse, simulate
from helpers.contract import ReductionContract


def _bandwidth(dut):
    """Where the DUT's |S| falls to |S0| / sqrt 2, by brentq on the closed form."""
    from scipy.optimize import brentq

    def g(f):
        s = 2j * np.pi * f
        wn = 2 * np.pi * dut.fn_hz
        return abs(wn**2 / (s**2 + 2 * dut.zeta * wn * s + wn**2)) - 1 / np.sqrt(2)

    return brentq(g, 1e-3 * dut.fn_hz, 10 * dut.fn_hz, xtol=1e-13, rtol=1e-15)


NOISE = 1e-3
"""Each channel's noise, V rms: about 1 % of the reference's 0.1 V at 1 g."""


class TestContract(ReductionContract):
    def truth(self, rng):
        return DutResponse(S0=rng.uniform(0.5, 3.0) * rng.choice([-1.0, 1.0]),
                           fn_hz=rng.uniform(300.0, 1500.0), zeta=rng.uniform(0.3, 1.0))

    def simulate(self, truth, rng, noisy):
        return simulate(truth, noise=NOISE if noisy else 0.0, seed=rng)

    def reduce(self, data):
        return fit_model(reduce_stepped(data), "second-order")

    def expected(self, truth):
        return [{"S0": truth.S0, "fn": truth.fn_hz, "zeta": truth.zeta,
                 "f_3dB": _bandwidth(truth)}]

    def default_case(self):
        # the rig's default DUT (a force-rebalance loop of 1.3 V/g, 600 Hz, zeta 0.6)
        dut = DutResponse()
        return simulate(dut, noise=0.0, seed=0), self.expected(dut)

    def noise_free_tolerance(self, name, value):
        # The points agree with the closed form to ~1e-15 relative (the sine fits' rounding);
        # the fit's conditioning (fn and zeta from 11 points) amplifies it by < 1e4.
        return 1e-11 * abs(value)
