"""The Reduction type and its one output path: rows, JSON, engineering units, table digits."""

import json
import math

import numpy as np
import pytest

from accelcal.cli.common import render
from accelcal.engineering import engineering
from accelcal.errors import AccelcalError
from accelcal.formatting import format_unit, format_value
from accelcal.identifiability import Combination
from accelcal.io.lab_metadata import LabInfo
from accelcal.outputs import describe
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.units import ARCSEC

# Dong2014 Table 1, sensor 1 (V, V/g, V/g^2)
K_F, K_I, K_O, K_IO, K_II = -8.336e-4, 1.2993698, -1.226e-5, 2.1e-6, 1.02e-5


def _head_like():
    names = ("K_F", "K_I", "K_O", "K_IO", "K_II")
    units = {"K_F": "V", "K_I": "V/g", "K_O": "V/g", "K_IO": "V/g^2", "K_II": "V/g^2"}
    std = np.array([1.1e-6, 3.0e-7, 1.2e-6, 2.0e-6, 1.5e-6])
    est = Estimate(names, [K_F, K_I, K_O, K_IO, K_II], np.diag(std**2), units, "x",
                   residuals=np.zeros(24), dof=19)
    return Reduction("dividing-head", "dividing-head/single", (est, est),
                     sensor_names=("U1", "U2"), dof=19,
                     assumptions=(Assumption("first_harmonic", "zero", "",
                                             "first harmonic of the angle error assumed zero"),),
                     nominal={"K_I": 1.3})


def test_engineering_units_of_dong2014_coefficients():
    # bias K_F / K_I in ug: -8.336e-4 / 1.2993698 g = -641.54 ug
    (bias,) = engineering("K_F", K_F, 1.1e-6, "V", scale_factor=K_I)
    assert bias.unit == "ug"
    assert bias.estimate == pytest.approx(K_F / K_I * 1e6, rel=1e-15)
    assert bias.std == pytest.approx(1.1e-6 / K_I * 1e6, rel=1e-15)
    # misalignment K_O / K_I in urad and arcsec (1 arcsec = 4.8481 urad)
    urad, arcsec = engineering("K_O", K_O, 1e-6, "V/g", scale_factor=K_I)
    assert (urad.unit, arcsec.unit) == ("urad", "arcsec")
    assert urad.estimate == pytest.approx(K_O / K_I * 1e6)
    assert arcsec.estimate == pytest.approx(K_O / K_I / ARCSEC)
    assert arcsec.estimate == pytest.approx(urad.estimate / 4.8481368, rel=1e-7)
    # second order in ug/g^2, scale factor in ppm from the nominal
    (k2,) = engineering("K_II", K_II, 1e-6, "V/g^2", scale_factor=K_I)
    assert (k2.unit, k2.estimate) == ("ug/g^2", pytest.approx(K_II / K_I * 1e6))
    (ppm,) = engineering("K_I", K_I, 3e-7, "V/g", nominal=1.3)
    assert ppm.estimate == pytest.approx((K_I - 1.3) / 1.3 * 1e6)
    assert engineering("K_I", K_I, 3e-7, "V/g") == ()  # no nominal, no ppm


def test_engineering_units_of_g_normalised_terms():
    assert engineering("K3", 1.19e-7, 1e-9, "g/g^3")[0].unit == "ug/g^3"
    (mg,) = engineering("Ko", 2e-3, 1e-5, "g/g", quantity="transverse")
    assert (mg.unit, mg.estimate) == ("mg/g", pytest.approx(2.0))
    assert engineering("K0_asym", 2.26e-6, 1e-8, "g")[0].estimate == pytest.approx(2.26)
    assert engineering("K1_asym", 1.45e-6, 1e-8, "g/g")[0].unit == "ppm"
    # an output-unit coefficient without a scale factor has no engineering unit
    assert engineering("K_F", K_F, 1e-6, "V") == ()
    assert engineering("K2", float("nan"), 1.0, "g/g^2") == ()


def test_rows_carry_raw_and_engineering_units():
    red = _head_like()
    rows = red.rows()
    assert len(rows) == 10
    first = rows[0]
    assert first["sensor"] == "U1"
    assert first["coefficient"] == "K_F"
    assert first["unit"] == "V"
    assert first["status"] == "fitted"
    assert first["dof"] == 19
    assert first["eng_unit"] == "ug"
    assert first["eng_estimate"] == pytest.approx(K_F / K_I * 1e6)
    k_o = next(r for r in rows if r["coefficient"] == "K_O")
    assert [e["unit"] for e in k_o["engineering"]] == ["urad", "arcsec"]
    k_i = next(r for r in rows if r["coefficient"] == "K_I")
    assert k_i["eng_unit"] == "ppm"


def test_json_is_complete_and_strict():
    red = _head_like()
    doc = json.loads(red.to_json())
    assert doc["family"] == "dividing-head"
    assert doc["method"] == "dividing-head/single"
    assert [s["sensor"] for s in doc["sensors"]] == ["U1", "U2"]
    assert doc["sensors"][0]["coefficients"][1] == {
        "name": "K_I", "unit": "V/g", "estimate": K_I, "std": pytest.approx(3e-7)}
    assert doc["assumptions"][0]["name"] == "first_harmonic"
    assert doc["sensors"][0]["engineering"]["K_F"][0]["unit"] == "ug"


def test_unidentified_coefficients_fixed_terms_and_combinations():
    nan = float("nan")
    est = Estimate(("K2", "K3", "K0_asym"), [nan, nan, 2e-6],
                   np.diag([nan, nan, 1e-16]), {"K2": "g/g^2", "K3": "g/g^3", "K0_asym": "g"},
                   "vre/identify", residuals=np.zeros(6), dof=4)
    red = Reduction("vre", "vre/identify", (est,), fixed={"K4": 0.0},
                    combinations=(Combination((("K2", 1.0), ("K3", 6.0)), 1e-5, 1e-7,
                                              "g/g^2"),))
    assert red.unidentified() == ("K2", "K3")
    rows = red.rows()
    assert [r["status"] for r in rows] == ["not identifiable", "not identifiable", "fitted",
                                           "fixed"]
    assert rows[-1]["unit"] == "g/g^4"
    text = describe(red)
    assert "not identifiable from this design: K2, K3" in text
    assert "K4 held fixed at 0" in text
    assert any(t.startswith("determined combination K2 + 6 K3 = ") for t in text)
    # records leave the undetermined values out
    (rec,) = red.to_records(LabInfo(("SN",), "", "2026-01-01T00:00:00+00:00"))
    assert rec.names == ("K0_asym",)
    doc = json.loads(red.to_json())
    assert doc["sensors"][0]["coefficients"][0]["estimate"] is None


def test_records_need_one_serial_per_sensor():
    red = _head_like()
    with pytest.raises(AccelcalError, match="2 sensors need 2 serial numbers") as info:
        red.to_records(LabInfo(("SN",), "", "2026-01-01T00:00:00+00:00"))
    assert info.value.parameter == "serial"
    recs = red.to_records(LabInfo(("A", "B"), "", "2026-01-01T00:00:00+00:00"))
    assert [r.serial for r in recs] == ["A", "B"]
    assert recs[0].notes[0] == "sensor column U1 of 2; reduction dividing-head/single"
    assert "first harmonic of the angle error assumed zero" in recs[0].notes


def test_table_keeps_the_digits_the_uncertainty_resolves():
    # K_I = 1.29936981234 V/g +- 3e-8: 7 significant digits would round away 0.8 uV/g
    rows = [{"coefficient": "K_I", "estimate": 1.29936981234, "std": 3e-8}]
    text = render(rows, "table")
    # two significant digits on the uncertainty (3.0e-8): the estimate to 1e-9
    assert format_value(1.29936981234, 3e-8) == "1.299369812"
    assert "1.299369812" in text
    # CSV keeps every digit; a list column is kept in JSON only
    rows = [{"coefficient": "K_O", "estimate": 1.5, "std": 0.1,
             "engineering": [{"unit": "urad", "estimate": 1.0, "std": math.nan}]}]
    assert "engineering" not in render(rows, "csv")
    assert json.loads(render(rows, "json"))[0]["engineering"][0]["std"] is None


def test_units_are_shown_with_powers_and_micro():
    assert format_unit("ug/g^2") == "µg/g²"
    assert format_unit("urad") == "µrad"
    assert format_unit("V/g^2") == "V/g²"
    assert format_unit("g/g^3") == "g/g³"


def test_errors_name_parameters_in_python_and_flags_on_the_command_line():
    exc = AccelcalError("must be a positive integer, got 0", parameter="first_harmonic_sd")
    assert str(exc) == "first_harmonic_sd: must be a positive integer, got 0"
    assert exc.message_for() == "--first-harmonic-sd: must be a positive integer, got 0"
    assert exc.message_for({"first_harmonic_sd": "--h1-sd"}).startswith("--h1-sd: ")
    assert str(AccelcalError("plain")) == "plain"


def test_an_overflow_is_never_a_result():
    with pytest.raises(AccelcalError, match="overflowed"):
        Estimate(("K0",), [1.0], [[math.inf]], {"K0": "g"}, "demo")
    with pytest.raises(AccelcalError, match="overflowed"):
        Estimate(("K0",), [-math.inf], [[1.0]], {"K0": "g"}, "demo")
    # NaN stays the mark of what the design does not determine
    Estimate(("K0",), [math.nan], [[math.nan]], {"K0": "g"}, "demo")


def test_command_line_nets_numerical_failures_and_memory(monkeypatch, capsys):
    import numpy as np

    from accelcal.cli import main

    def fail(*args, **kwargs):
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setattr("accelcal.cli.model.load_model", fail, raising=False)
    monkeypatch.setattr("accelcal.cli.common.load_model", fail)
    with pytest.raises(SystemExit) as info:
        main(["model", "show"])
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert err.startswith("accelcal: error: the computation failed (SVD did not converge)")
    assert err.count("\n") == 1
