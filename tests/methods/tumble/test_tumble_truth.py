"""Every tumble row is what its name says, noise-free, for the embedded default accelerometer.

The default accelerometer has every model term non-zero (Kpp, Koo, K0', K1'
included): the Fourier route names the rows Kpp (Koo) enters and bounds K0'
and K1' by their priors; the least-squares route estimates K0' and K1'.
"""


import numpy as np
import pytest

import accelcal
from accelcal.errors import AccelcalError
from accelcal.methods.tumble import reduce_tumble, specific_force
from helpers.contract import true_value


def _default_tumble(axis, n=24):
    model = accelcal.default_model()
    theta = np.arange(n) * 2 * np.pi / n
    return model, theta, model.output(*specific_force(theta, axis))


@pytest.mark.parametrize("axis", ["OA", "PA"])
@pytest.mark.parametrize("route", ["fourier", "lsq"])
def test_every_row_equals_its_truth_within_its_stated_uncertainty(axis, route):
    model, theta, y = _default_tumble(axis)
    red = reduce_tumble(theta, y, rotation_axis=axis, route=route)
    cross = "Kpp" if axis == "OA" else "Koo"
    names = [r["coefficient"] for r in red.rows()]
    assert f"K0+{cross}" in names
    assert f"K2-{cross}" in names
    for row in red.rows():
        err = row["estimate"] - true_value(model, row["coefficient"])
        # rounding of ~1.3 V outputs: 1e-14 absolute
        assert abs(err) <= row["std"] + 1e-14, (row["coefficient"], err, row["std"])


def test_fourier_route_itemises_the_asymmetry_priors():
    model, theta, y = _default_tumble("OA")
    red = reduce_tumble(theta, y, route="fourier")
    k3 = red.contributions("K3")
    assert [c.input for c in k3] == ["K0_asym"]  # sgn(a_i)/2 feeds the odd harmonics
    assert k3[0].source == "default"
    # without the prior K3 would be six of its Type A SDs off (issue 24)
    none = reduce_tumble(theta, y, route="fourier", priors=None)
    err = none.estimate["K3"] - model.K3
    assert abs(err) > 5 * none.estimate.std_of("K3")
    assert abs(err) <= red.estimate.std_of("K3")
    moved = {a.row for a in none.aliases if a.term == "K0_asym"}
    assert {"K1", "K3"} <= moved
    assert not none.type_b
    # the alias matrix predicts the error: K3 moves by A * K0' (first order in K0'/K1 terms)
    a = next(a.sensitivity for a in none.aliases if a.term == "K0_asym" and a.row == "K3")
    assert err == pytest.approx(a * model.K0_asym, rel=1e-3)


def test_least_squares_route_estimates_the_asymmetry_where_the_positions_separate_it():
    model, theta, y = _default_tumble("OA")
    red = reduce_tumble(theta, y, route="lsq")
    assert red.estimate["K0_asym"] == pytest.approx(model.K0_asym, rel=1e-6)
    assert red.estimate["K1_asym"] == pytest.approx(model.K1_asym, rel=1e-6)
    assert not red.type_b
    assert red.estimate["K0+Kpp"] == red.estimate["K0"]
    off = reduce_tumble(theta, y, route="lsq", asymmetry=False)
    assert "K0_asym" not in off.estimate.names
    assert {c.input for c in off.type_b} == {"K0_asym", "K1_asym"}


def test_asymmetry_required_where_the_positions_cannot_separate_it_is_refused():
    _, theta, y = _default_tumble("OA", n=8)
    with pytest.raises(AccelcalError, match="cannot separate the asymmetry"):
        reduce_tumble(theta, y, route="lsq", asymmetry=True)


def test_records_keep_the_row_name_and_the_plain_name():
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.io.lab_metadata import LabInfo

    _, theta, y = _default_tumble("OA")
    red = reduce_tumble(theta, y)
    (rec,) = red.to_records(LabInfo(("SN1",), "op", "2026-01-02T03:04:05+00:00"))
    back = CalibrationRecord.from_json(rec.to_json())
    assert "K0+Kpp" in back.names
    assert back.plain["K0+Kpp"] == "K0"
    assert any("Type B" in n or "priors" in n for n in back.notes)
    doc = red.to_dict()
    assert doc["sensors"][0]["coefficients"][0]["plain"] == "K0"
    assert {c["input"] for c in doc["type_b"]} == {"K0_asym", "K1_asym"}
