"""The `accelcal` command: version, help, model show/new/eval, error policy."""

import json
import subprocess
import sys

import numpy as np
import pytest

import accelcal
from accelcal import ErrorModel, default_model
from accelcal.cli import main


def run(capsys, *args):
    with pytest.raises(SystemExit) as info:
        main(list(args))
    out, err = capsys.readouterr()
    return info.value.code, out, err


def test_version(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == 0
    assert out.strip() == f"accelcal {accelcal.__version__}"


def test_help_lists_commands(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0
    assert "model" in out
    code, out, _ = run(capsys, "model", "--help")
    assert code == 0
    for command in ("show", "new", "eval"):
        assert command in out


def test_show_default_lists_every_term_with_units(capsys):
    code, out, _ = run(capsys, "model", "show", "--format", "csv")
    assert code == 0
    lines = out.strip().splitlines()
    assert lines[0] == "term,value,unit,description"
    rows = {line.split(",")[0]: line.split(",") for line in lines[1:]}
    assert list(rows) == list(default_model().terms())
    assert rows["K1"][2] == "V/g"
    assert float(rows["K2"][1]) == default_model().K2


def test_show_table_and_json(capsys, tmp_path):
    code, out, _ = run(capsys, "model", "show")
    assert code == 0
    assert "K0_asym" in out
    assert "embedded default" in out
    code, out, _ = run(capsys, "model", "show", "--format", "json")
    assert ErrorModel.from_json(out) == default_model()


def test_new_sets_terms_and_zeroes_the_rest(capsys, tmp_path):
    path = tmp_path / "m.json"
    code, out, _ = run(
        capsys, "model", "new", "--set", "K2=7.87e-6", "--set", "K0_asym=2.26e-6",
        "--set", "Kio=-1e-5", "--output-unit", "mA", "--out", str(path),
    )
    assert code == 0
    assert str(path) in out
    expected = ErrorModel(K2=7.87e-6, K0_asym=2.26e-6, Kio=-1e-5, output_unit="mA")
    assert ErrorModel.load(path) == expected
    code, out, _ = run(capsys, "model", "show", str(path), "--format", "csv")
    assert "K1,1.0,mA/g" in out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--set", "K9=1"], "unknown term 'K9'"),
        (["--set", "K2"], "is not NAME=VALUE"),
        (["--set", "K2=abc"], "--set K2: 'abc' is not a number"),
        (["--set", "K2=nan"], "--set K2: 'nan' is not finite"),
        (["--set", "K2=1", "--set", "K2=2"], "gives K2 twice"),
        (["--set", "K1=0"], "K1 \\(scale factor\\) is 0"),
        (["--output-unit", "uV"], "output_unit 'uV'"),
    ],
)
def test_new_bad_input_exits_2_and_writes_nothing(capsys, tmp_path, args, message):
    path = tmp_path / "m.json"
    code, _, err = run(capsys, "model", "new", *args, "--out", str(path))
    assert code == 2
    assert err.startswith("accelcal: error: ")
    assert len(err.strip().splitlines()) == 1
    assert __import__("re").search(message, err)
    assert not path.exists()


def test_eval_matches_model_output(capsys, tmp_path):
    path = tmp_path / "m.json"
    model = default_model().replace(output_unit="mA")
    model.save(path)
    code, out, _ = run(capsys, "model", "eval", "--ai", "-1:1:0.5", "--ao", "0.1",
                       "--ap", "-0.2", "--model", str(path), "--format", "json")
    assert code == 0
    rows = json.loads(out)
    a_i = np.array([r["a_i_g"] for r in rows])
    np.testing.assert_array_equal(a_i, [-1.0, -0.5, 0.0, 0.5, 1.0])
    expected = model.output(a_i, 0.1, -0.2)
    np.testing.assert_array_equal([r["output_mA"] for r in rows], expected)
    np.testing.assert_array_equal([r["output_g"] for r in rows], expected / model.K1)


def test_eval_default_model_and_negative_values(capsys):
    code, out, _ = run(capsys, "model", "eval", "--ai", "-1", "--format", "csv")
    assert code == 0
    header, row = out.strip().splitlines()
    assert header == "a_i_g,a_o_g,a_p_g,output_V,output_g"
    assert float(row.split(",")[3]) == float(default_model().output(-1.0))


def test_eval_unequal_lists(capsys):
    code, _, err = run(capsys, "model", "eval", "--ai", "0,1", "--ao", "0,1,2")
    assert code == 2
    assert "different lengths (--ai has 2, --ao has 3" in err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["model", "eval", "--ai", "abc"], "--ai: 'abc' is not a number"),
        (["model", "eval", "--ai", "1", "--model", "no-such-model.json"],
         "model file no-such-model.json not found"),
        (["model", "eval"], "Missing option '--ai'"),
        (["model", "frobnicate"], "No such command 'frobnicate'"),
    ],
)
def test_bad_input_one_line_exit_2_no_traceback(tmp_path, args, message):
    """Through the installed console entry point, in a fresh process."""
    proc = subprocess.run(
        [sys.executable, "-c", "from accelcal.cli import main; main()", *args],
        capture_output=True, text=True, cwd=tmp_path, check=False,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("accelcal: error: ")
    assert message in lines[0]
    assert "Traceback" not in proc.stderr
