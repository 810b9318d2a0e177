"""The lab file: the example read in full, and every kind of bad lab file refused in one line."""

import datetime as dt
import math

import pytest

from accelcal.budget.lab import QUANTITIES, UNITS, load_lab
from accelcal.errors import AccelcalError
from helpers.budget import LAB_HEAD, lab_text, standard
from helpers.cli import assert_one_line_error, run_cli
from helpers.paths import ROOT

EXAMPLE = ROOT / "examples" / "lab.toml"


def test_the_example_lab_file():
    lab = load_lab(EXAMPLE)
    assert lab.laboratory.name.startswith("Inertial Sensors Laboratory")
    assert lab.laboratory.accreditation
    assert next(s.role for s in lab.signatories) == "Head of laboratory"
    assert lab.customer["name"]
    assert lab.environment["temperature_degC"] == 23.0
    assert len(lab.sha256) == 64
    g = lab.standards["local_gravity"]
    assert g.u == pytest.approx(0.025e-5)  # U = 0.05 mGal, k = 2, in m/s^2
    assert g.dof == pytest.approx(50.0)  # reliability 0.1
    assert g.value_in("mGal") == pytest.approx(981261.7)
    head = lab.standards["head_angle"]
    assert (head.distribution, head.u) == ("rectangular", pytest.approx(1 / math.sqrt(3)))
    ref = lab.standards["reference_sensitivity"]
    assert ref.u == pytest.approx(0.025)  # 0.5 % (k = 2) of 10 mV/g
    assert lab.standards["centrifuge_radius"].u == pytest.approx(20e-6)
    assert lab.correlations == {("daq_gain", "load_resistor"): 0.2}
    assert set(lab.standards) <= set(QUANTITIES)
    assert lab.expired(dt.date(2026, 11, 26)) == []
    assert {s.quantity for s in lab.expired(dt.date(2029, 4, 1))} == {"head_angle",
                                                                    "head_axis_tilt",
                                                                    "sensor_temperature"}


def test_every_quantity_has_its_usual_unit():
    for name, (dims, unit, _) in QUANTITIES.items():
        assert any(unit in UNITS[d] for d in dims), name


def test_an_expired_standard_is_named(write_lab):
    lab = load_lab(write_lab(lab_text(standard("daq_gain", 0, "ppm", due="2020-01-31", u=3,
                                               certificate="DMM-1"))))
    with pytest.raises(AccelcalError, match=r"daq_gain \(certificate DMM-1, due 2020-01-31\)"):
        lab.check_due()


BAD = {
    "missing value": (standard("daq_gain", 0, "ppm", u=1).replace("value = 0\n", ""),
                      "missing value"),
    "two uncertainty forms": (standard("daq_gain", 0, "ppm", u=1, U=2, k=2), "exactly once"),
    "no uncertainty": (standard("daq_gain", 0, "ppm"), "exactly once"),
    "U without k": (standard("daq_gain", 0, "ppm", U=2), "needs its coverage factor"),
    "bounds without distribution": (standard("head_angle", 0, "arcsec", bounds=1),
                                    "bounds need a distribution"),
    "unit does not fit": (standard("local_gravity", 9.81, "arcsec", u=1e-7),
                          "does not fit local_gravity"),
    "uncertainty unit does not fit": (standard("local_gravity", 9.81, "m/s^2", u=1,
                                               uncertainty_unit="ohm"), "uncertainty_unit"),
    "negative u": (standard("daq_gain", 0, "ppm", u=-1), "negative"),
    "non-finite u": (standard("daq_gain", 0, "ppm", u=math.nan), "not finite"),
    "infinite U": (standard("daq_gain", 0, "ppm", U=math.inf, k=2), "not finite"),
    "zero k": (standard("daq_gain", 0, "ppm", U=1, k=0), "k = 0.0 must be > 0"),
    "dof and reliability": (standard("daq_gain", 0, "ppm", u=1, dof=3, reliability=0.1),
                            "not both"),
    "unknown quantity": (standard("flux_capacitor", 0, "ppm", u=1), "unknown quantity"),
    "unknown key": (standard("daq_gain", 0, "ppm", u=1, colour="red"), "unknown key"),
    "duplicate quantity": (standard("daq_gain", 0, "ppm", u=1) * 2, "declared twice"),
    "correlation outside [-1, 1]": (
        standard("daq_gain", 0, "ppm", u=1) + standard("daq_offset", 0, "uV", u=1)
        + '[[correlation]]\nquantities = ["daq_gain", "daq_offset"]\nr = 1.5\n', "outside"),
    "correlation of an unknown quantity": (
        standard("daq_gain", 0, "ppm", u=1)
        + '[[correlation]]\nquantities = ["daq_gain", "load_resistor"]\nr = 0.1\n',
        "not a declared standard"),
    "bad due date": (standard("daq_gain", 0, "ppm", due='"soon"', u=1), "is not a date"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_lab_files_one_line_exit_2(case, write_lab, tumble_file, capsys):
    body, needle = BAD[case]
    path = write_lab(LAB_HEAD + "\n" + body)
    code, _, err = run_cli(["budget", tumble_file, "--lab", path], capsys)
    assert_one_line_error(code, err, "--lab", needle)


def test_no_laboratory_section_and_not_toml(write_lab, tumble_file, capsys):
    code, _, err = run_cli(["budget", tumble_file, "--lab",
                            write_lab(standard("daq_gain", 0, "ppm", u=1))], capsys)
    assert_one_line_error(code, err, "missing [laboratory]")
    code, _, err = run_cli(["budget", tumble_file, "--lab", write_lab("this is = = not toml")],
                           capsys)
    assert_one_line_error(code, err, "not a TOML file")
    code, _, err = run_cli(["budget", tumble_file, "--lab", ROOT / "no-such-lab.toml"], capsys)
    assert_one_line_error(code, err, "cannot read lab file")


def test_expired_standard_refused_unless_allowed(write_lab, tumble_file, capsys):
    path = write_lab(lab_text(standard("daq_gain", 0, "ppm", due="2020-01-31", u=3)))
    code, _, err = run_cli(["budget", tumble_file, "--lab", path], capsys)
    assert_one_line_error(code, err, "expired standard", "daq_gain")
    code, out, err = run_cli(["budget", tumble_file, "--lab", path, "--allow-expired",
                              "--format", "json"], capsys)
    assert code == 0
    assert "warning: expired standard(s) used: daq_gain (due 2020-01-31)" in err
    assert "past their due date" in out


def test_an_expired_standard_the_method_does_not_use_is_not_refused(write_lab, tumble_file,
                                                                      capsys):
    path = write_lab(lab_text(standard("centrifuge_radius", 0.5, "m", due="2020-01-31", u=1e-5),
                              standard("daq_gain", 0, "ppm", u=3)))
    code, out, err = run_cli(["budget", tumble_file, "--lab", path, "--format", "json"], capsys)
    assert code == 0, err
    assert "expired" not in err
    assert "past their due date" not in out
