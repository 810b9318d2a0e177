"""The indexing head's budget through the reduction's linear response, checked by re-running it.

The sensitivities to the inputs entering through the data (each position's
angle, the autocollimator, the DAQ's gain, offset and linearity) come from
the route's first-order response; re-running the reduction on the
perturbed data (central differences) is the check: each input's
contribution agrees to 1e-4 of the coefficient's combined standard
uncertainty (the linearisation leaves out the residuals' and the estimated
angle errors' second-order parts, ~1e-6 of u_c on the example).
"""

import numpy as np
import pytest

from accelcal.budget.engine import itemise
from accelcal.budget.lab import load_lab
from accelcal.catalog import METHODS
from helpers.paths import EXAMPLES, ROOT

DATA_ENTERING = ("head_angle", "autocollimator", "daq_gain", "daq_offset", "daq_linearity")
TOLERANCE = 1e-4
"""Largest difference of a contribution, relative to the coefficient's u_c."""


@pytest.fixture(scope="module")
def head():
    from accelcal.io.formats.dividing_head import read_head_record

    record = read_head_record(EXAMPLES / "indexing_head.csv")
    lab = load_lab(ROOT / "examples" / "lab.toml")
    inputs = next(m for m in METHODS if m.family == "dividing-head").budget_inputs
    return record, lab, inputs


def _itemised(head, route, rerun):
    from accelcal.methods.dividing_head import reduce
    from accelcal.methods.dividing_head.budget import data_model

    record, lab, inputs = head
    red = reduce(record, route)
    return itemise(red, lab, data_model=data_model(red, record, rerun=rerun), inputs=inputs)


@pytest.mark.parametrize("route", [pytest.param("joint", marks=pytest.mark.slow), "single"])
def test_linear_response_agrees_with_the_reduction_run_again(head, route):
    exact = _itemised(head, route, rerun=True)
    linear = _itemised(head, route, rerun=False)
    assert [b.coefficient for b in linear] == [b.coefficient for b in exact]
    seen = set()
    for e, f in zip(exact, linear, strict=True):
        rows = {r.quantity: r for r in f.rows}
        for r in e.rows:
            if r.quantity not in DATA_ENTERING:
                continue
            seen.add(r.quantity)
            assert abs(rows[r.quantity].contribution - r.contribution) <= TOLERANCE * e.u_c, (
                e.coefficient, r.quantity)
            if r.components:  # each position's signed sensitivity, not only their sum of squares
                gap = np.abs(np.subtract(rows[r.quantity].components, r.components)) * r.u
                assert gap.max() <= TOLERANCE * e.u_c, (e.coefficient, r.quantity)
        assert f.u_c == pytest.approx(e.u_c, rel=TOLERANCE)
    assert seen >= {"head_angle", "daq_gain", "daq_offset", "daq_linearity"}
    # the angles matter: a wrong slope (e.g. of the wrong sign's basis) would show
    scale = max(r.contribution for b in exact for r in b.rows if r.quantity == "head_angle")
    assert scale > 1e-3 * max(b.u_c for b in exact)


def test_the_linear_model_is_not_used_where_the_route_is_not_psi(head):
    from accelcal.methods.dividing_head import HeadData
    from accelcal.methods.dividing_head.budget import linearised

    record, _, _ = head
    data = HeadData.from_record(record)
    assert linearised(data, "tumble", {}) is None
    assert linearised(data, "joint", {}) is not None
