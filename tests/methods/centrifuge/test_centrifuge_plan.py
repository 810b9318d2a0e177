"""Centrifuge test planning (issue 14 item 3): analytic predictions confirmed by Monte Carlo.

:func:`accelcal.methods.centrifuge.plan` predicts each coefficient's standard
uncertainty from the levels, positions and rig uncertainties; the Monte Carlo
engine runs the rig and the reduction (:mod:`accelcal.methods.centrifuge.mc`)
and the SDs of the errors must agree within the sampling error of an SD of
M trials, 1 / sqrt(2 (M - 1)) (5 % at 200: 4 SE = 20 %, a 1e-4 false alarm).
"""

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.centrifuge import plan
from accelcal.methods.centrifuge.mc import PlanSampler, plan_monte_carlo

LEVELS = (5.0, 10.0, 20.0, 30.0, 40.0, 50.0)
TRIALS = 200


@pytest.mark.slow
@pytest.mark.parametrize(("positions", "kwargs", "estimate", "one_g"), [
    (("IA-in", "IA-out", "IA-tan"), {"radius_sd": 1e-4}, (), 0),
    (("IA-in", "IA-out", "OA-in", "OA-out", "PA-in", "PA-out", "IA-tan"),
     {"radius_sd": 1e-4, "misalignment_sd": 2e-7}, (), 0),
    (("IA-in", "IA-out", "OA-in", "IA-tan"), {}, ("radius_error",), 16),
])
def test_plan_is_confirmed_by_monte_carlo(positions, kwargs, estimate, one_g):
    p = plan(positions, LEVELS, noise_sd=2e-6, readings=2, radius=1.5, estimate=estimate,
             one_g_positions=one_g, **kwargs)
    sds = {"radius_error": kwargs.get("radius_sd", 0.0),
           "misalignment": kwargs.get("misalignment_sd", 0.0)}
    sampler = PlanSampler(positions, LEVELS, p.terms, estimate, noise_sd=2e-6, readings=2,
                          radius=1.5, sds={k: v for k, v in sds.items() if v},
                          one_g_positions=one_g)
    mc = plan_monte_carlo(sampler, TRIALS, seed=7)
    ratio = mc.std / p.sd
    assert np.all(np.abs(ratio - 1) < 4 / np.sqrt(2 * (TRIALS - 1))), dict(zip(p.names, ratio,
                                                                               strict=True))
    assert np.all(np.abs(mc.mean) < 4 * p.sd / np.sqrt(TRIALS) + 1e-15)


def test_plan_says_what_the_design_separates():
    horizontal = plan(("IA-in", "IA-out", "IA-tan"), LEVELS, radius_sd=1e-4)
    text = " ".join(horizontal.identifiability.statements())
    assert "radius_error cannot be separated from K1" in text
    assert "Kio is not excited" in text
    # the radius SD dominates K1's relative SD when the records cannot see it
    assert horizontal.as_dict()["K1"] == pytest.approx(1e-4, rel=1e-3)
    joint = plan(("IA-in", "IA-out", "IA-tan"), LEVELS, estimate=("radius_error",),
                 one_g_positions=24)
    assert "radius_error" in joint.names
    assert joint.as_dict()["K1"] < 1e-5
    with pytest.raises(AccelcalError, match="cannot be separated from K1"):
        plan(("IA-in", "IA-out", "IA-tan"), LEVELS, estimate=("radius_error",))
    # more readings per step: noise-limited SDs fall as 1/sqrt(n)
    a = plan(("IA-in", "IA-out"), LEVELS, readings=1).as_dict()
    b = plan(("IA-in", "IA-out"), LEVELS, readings=4).as_dict()
    assert b["K2"] == pytest.approx(a["K2"] / 2, rel=1e-12)


@pytest.mark.parametrize(("kwargs", "parameter"), [
    ({"levels": (10.0,)}, "levels"), ({"positions": ("IA-in", "IA-in")}, "positions"),
    ({"noise_sd": 0.0}, "noise_sd"), ({"radius_sd": -1.0}, "radius_sd"),
    ({"estimate": ("bogus",)}, "estimate"), ({"one_g_positions": -3}, "one_g_positions"),
    ({"readings": 0}, "readings"),
])
def test_plan_refuses_bad_input(kwargs, parameter):
    args = {"positions": ("IA-in", "IA-out"), "levels": LEVELS, **kwargs}
    with pytest.raises(AccelcalError) as exc:
        plan(args.pop("positions"), args.pop("levels"), **args)
    assert exc.value.parameter == parameter
