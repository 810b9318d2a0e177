"""With ``--uncertainty mc`` the engineering units carry the Monte Carlo SD (table, JSON)."""

import json

import pytest

from accelcal.cli import main
from accelcal.formatting import format_std


def run(args, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    return out


def test_triad_calibrate_engineering_sd_is_the_monte_carlo_one(tmp_path, capsys):
    triad = tmp_path / "triad.csv"
    run(["triad", "simulate", "--positions", "six", "--out", triad], capsys)
    base = ["triad", "calibrate", triad, "--out", tmp_path / "cal.json", "--format", "json"]
    formal = json.loads(run(base, capsys))["coefficients"]
    mc = json.loads(run([*base, "--uncertainty", "mc", "--trials", "300"], capsys))["coefficients"]
    biases = 0
    for r, f in zip(mc, formal, strict=True):
        for e, ef in zip(r["engineering"], f["engineering"], strict=True):
            assert e["unit"] == ef["unit"]
            assert e["estimate"] == ef["estimate"]
            assert e["std"] == pytest.approx(ef["std"] * r["mc_std"] / r["std"], rel=1e-12)
            biases += e["unit"] == "ug"
    assert biases == 3


def test_the_table_shows_the_monte_carlo_sd_in_engineering_units(tmp_path, capsys):
    head = tmp_path / "head.csv"
    run(["dividing-head", "simulate", "--angle-error", "uniform:2arcsec", "--seed", "1",
         "--out", head], capsys)
    args = ["dividing-head", "reduce", head, "--method", "single", "--uncertainty", "mc",
            "--trials", "2000", "--angle-error-level", "4arcsec"]
    rows = json.loads(run([*args, "--format", "json"], capsys))
    table = run([*args, "--format", "table"], capsys)
    k_f = next(r for r in rows if r["plain"] == "K_F")
    assert k_f["mc_std"] > 1.5 * k_f["std"]  # the head's angle errors widen it
    formal = json.loads(run([*args[:5], "--format", "json"], capsys))
    in_ug = next(r for r in formal if r["plain"] == "K_F")["eng_std"] / k_f["std"]
    line = next(ln for ln in table.splitlines() if " K_F+K_OO " in ln)
    assert f"± {format_std(k_f['mc_std'] * in_ug)} µg" in line
    assert f"± {format_std(k_f['std'] * in_ug)} µg" not in line
