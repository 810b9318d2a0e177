"""``accelcal budget``: table, CSV and JSON of a tumble record; a calibration record's budget."""

import json

import pytest

from helpers.budget import lab_text, standard
from helpers.cli import assert_one_line_error, run_cli
from helpers.paths import EXAMPLES, ROOT

LAB = ROOT / "examples" / "lab.toml"
BUDGET_KEYS = {"coefficient", "estimate", "unit", "u_c", "nu_eff", "k", "U", "correlated",
               "rows", "sensor", "serial", "notes"}
ROW_KEYS = {"quantity", "estimate", "u", "unit", "distribution", "sensitivity",
            "contribution", "dof", "share", "source", "reference"}


def test_json_keys_as_the_issue_states(tumble_file, capsys):
    code, out, err = run_cli(["budget", tumble_file, "--lab", LAB, "--format", "json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert {b["coefficient"] for b in doc} >= {"K0+Kpp", "K1", "K2-Kpp"}
    for b in doc:
        assert set(b) == BUDGET_KEYS  # the issue's nine, and sensor, serial, notes
        for row in b["rows"]:
            assert set(row) == ROW_KEYS
            assert row["dof"] == "inf" or row["dof"] > 0
    k1 = next(b for b in doc if b["coefficient"] == "K1")
    assert k1["unit"] == "ppm"
    assert k1["U"] == pytest.approx(k1["k"] * k1["u_c"])
    assert k1["rows"][0]["quantity"] == "daq_gain"  # 8 ppm: the largest
    # the example's voltage output: the load resistor is named as not applicable
    assert any("load_resistor: not applicable" in n for n in k1["notes"])


def test_table_and_csv(tumble_file, capsys):
    code, out, _ = run_cli(["budget", tumble_file, "--lab", LAB, "--coefficient", "K1"],
                           capsys)
    assert code == 0
    assert "U1 K1" in out
    assert "daq_gain" in out
    assert "share" in out
    assert "u_c = " in out
    assert "nu_eff = " in out
    assert "(95.45 %)" in out
    assert "K2-Kpp" not in out
    code, out, _ = run_cli(["budget", tumble_file, "--lab", LAB, "--coefficient", "K1",
                            "--format", "csv"], capsys)
    lines = out.strip().splitlines()
    assert lines[0].startswith("serial,coefficient,coefficient_unit,value,u_c,nu_eff,k,U,"
                               "quantity,estimate,u,unit,distribution,sensitivity,")
    assert lines[1].split(",")[8] == "daq_gain"


def test_missing_inputs_warn_in_one_line(tumble_file, write_lab, capsys):
    lab = write_lab(lab_text(standard("local_gravity", 9.81, "m/s^2", u=1e-6)))
    code, out, err = run_cli(["budget", tumble_file, "--lab", lab, "--format", "json"], capsys)
    assert code == 0
    warning = [line for line in err.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1
    assert "daq_gain" in warning[0]
    assert "head_angle" in warning[0]
    assert "tumble" in warning[0]
    doc = json.loads(out)
    assert {r["quantity"] for r in doc[0]["rows"]} >= {"Type A", "local_gravity"}
    assert "daq_gain" not in {r["quantity"] for r in doc[0]["rows"]}


def test_without_a_lab_the_type_a_and_priors(tumble_file, capsys):
    code, out, _ = run_cli(["budget", tumble_file, "--format", "json"], capsys)
    assert code == 0
    quantities = {r["quantity"] for b in json.loads(out) for r in b["rows"]}
    assert "Type A" in quantities
    assert any(q.startswith("prior ") for q in quantities)
    assert not quantities & {"daq_gain", "local_gravity"}
    assert "no lab file given: the Type A part and the priors only" in json.loads(out)[0]["notes"]


def test_check_mc_reports_both_intervals(tumble_file, capsys):
    code, out, _ = run_cli(["budget", tumble_file, "--lab", LAB, "--coefficient", "K1",
                            "--check", "mc", "--mc-model", "linear", "--trials", "20000",
                            "--format", "json"], capsys)
    assert code == 0
    c = json.loads(out)[0]["check"]
    assert c["model"] == "linearised"
    assert c["trials"] == 20000
    assert c["mc_low"] < c["mc_high"]
    assert c["gum_low"] < c["gum_high"]
    assert isinstance(c["validated"], bool)
    code, out, _ = run_cli(["budget", tumble_file, "--lab", LAB, "--coefficient", "K1",
                            "--check", "mc", "--mc-model", "linear", "--trials", "20000"],
                           capsys)
    assert "Monte Carlo (20000 trials, linearised model): 95.45 % interval" in out


@pytest.mark.parametrize(("args", "needle"), [
    (["--check", "bootstrap"], "--check"),
    (["--trials", "5000"], "go with --check mc"),
    (["--check", "mc", "--trials", "10"], "at least 100"),
    (["--check", "mc", "--mc-model", "linear", "--trials", "500"], "at least 1000"),
    (["--check", "mc", "--mc-model", "exact"], "--mc-model"),
    (["--check", "mc", "--mc-model", "linear", "--workers", "2"], "go with --mc-model reduction"),
    (["--workers", "2"], "go with --check mc"),
    (["--timeout", "nan"], "timeout"),
    (["--coefficient", "K9"], "no reported coefficient"),
    (["--format", "xml"], "--format"),
    (["--data", "no-such-directory"], "--data"),
])
def test_bad_options_one_line(tumble_file, capsys, args, needle):
    code, _, err = run_cli(["budget", tumble_file, *args], capsys)
    assert_one_line_error(code, err, needle)


def test_a_triad_calibration_file_is_named(capsys):
    code, _, err = run_cli(["budget", EXAMPLES / "triad_calibration.json"], capsys)
    assert_one_line_error(code, err, "triad calibration file")


@pytest.mark.slow
def test_calibration_record_of_the_indexing_head(capsys):
    code, out, err = run_cli(["budget", EXAMPLES / "calibration_record.json", "--lab", LAB,
                              "--format", "json", "--data", EXAMPLES], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert {b["coefficient"] for b in doc} == {"K_F+K_OO", "K_I", "K_O", "K_IO", "K_II-K_OO"}
    assert {b["serial"] for b in doc} == {"ACC-0001"}  # the record's sensor only
    k_i = next(b for b in doc if b["coefficient"] == "K_I")
    gain = next(r for r in k_i["rows"] if r["quantity"] == "daq_gain")
    assert gain["sensitivity"] == pytest.approx(1.0, rel=1e-3)
    assert {r["quantity"] for r in k_i["rows"]} >= {"Type A", "head_angle", "local_gravity"}


def test_model_file_gives_the_temperature_sensitivity(tumble_file, write_lab, tmp_path, capsys):
    from accelcal.model import ErrorModel
    from accelcal.terms import TemperatureTerms

    model = tmp_path / "model.json"
    ErrorModel(K1=1.3, temperature=TemperatureTerms(25.0, {"K0_T1": 5e-6})).save(model)
    lab = write_lab(lab_text(standard("sensor_temperature", 23.0, "degC", u=0.2)))
    code, out, err = run_cli(["budget", tumble_file, "--lab", lab, "--model", model,
                              "--coefficient", "K0+Kpp", "--format", "json"], capsys)
    assert code == 0, err
    row = next(r for r in json.loads(out)[0]["rows"] if r["quantity"] == "sensor_temperature")
    assert row["sensitivity"] == pytest.approx(5.0)  # ug/degC
    assert row["contribution"] == pytest.approx(1.0)


def test_a_response_record_one_budget_per_point_and_part(tmp_path, write_lab, capsys):
    from accelcal.io.formats.response import write
    from accelcal.methods import response

    path = tmp_path / "response.csv"
    write(path, response.simulate(seed=2, frequencies=(20.0, 160.0)))
    code, out, err = run_cli(["budget", path, "--lab", LAB, "--format", "json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert [b["coefficient"] for b in doc] == ["S(20 Hz) magnitude", "S(20 Hz) phase",
                                               "S(160 Hz) magnitude", "S(160 Hz) phase"]
    assert [b["unit"] for b in doc] == ["%", "deg"] * 2
    assert "warning" not in err  # the example lab declares every input
    code, out, _ = run_cli(["budget", path, "--lab", LAB, "--coefficient", "S(160 Hz)",
                            "--format", "json"], capsys)
    assert [b["coefficient"] for b in json.loads(out)] == ["S(160 Hz) magnitude",
                                                          "S(160 Hz) phase"]
    bare = write_lab(lab_text(standard("reference_sensitivity", 10.0, "mV/g", u=0.05)))
    code, out, err = run_cli(["budget", path, "--lab", bare, "--format", "json"], capsys)
    warning = [line for line in err.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1
    assert "daq_delay_mismatch" in warning[0]
    assert "relative_motion" in warning[0]
