"""Before/after comparison of two calibration records and repeatability over a serial's records."""

import math
from dataclasses import replace

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance import compare, repeatability
from helpers.cli import run_cli
from helpers.records import make_record, records


def test_shift_its_uncertainty_en_and_z_against_closed_forms():
    one = make_record(date="2026-01-01T00:00:00+00:00")
    two = make_record(date="2026-02-01T00:00:00+00:00", shift=5e-6)
    rows = {r["quantity"]: r for r in compare(one, two)}
    k_i = 1.2993698
    f = rows["K_F"]
    # K_F in V over the record's own K_I, in ug; each u = 1e-6 V / K_I
    assert f["std"] == pytest.approx(math.hypot(1e-6, 1e-6) / k_i * 1e6, rel=1e-3)
    assert f["En"] == pytest.approx(f["estimate"] / (2 * f["std"]))
    from scipy.special import ndtr

    assert f["p"] == pytest.approx(2 * ndtr(-abs(f["estimate"]) / f["std"]))
    assert f["statistic"] == "z"
    i = rows["K_I"]
    assert i["unit"] == "ppm"
    assert i["estimate"] == pytest.approx(5e-6 / k_i * 1e6, rel=1e-6)
    assert i["exceeds"] is (abs(i["En"]) > 1)


def test_welch_t_when_both_records_state_their_dof():
    one = replace(make_record(date="2026-01-01T00:00:00+00:00"), dof=4)
    two = replace(make_record(date="2026-02-01T00:00:00+00:00", shift=5e-6), dof=4)
    row = compare(one, two)[0]
    assert row["statistic"] == "t"
    assert row["dof"] == pytest.approx(8.0)  # equal u: nu = (2u^2)^2 / (2 u^4 / 4)
    from scipy.special import stdtr

    assert row["p"] == pytest.approx(2 * stdtr(8.0, -abs(row["value"])))


def test_records_of_different_serials_or_methods_are_refused():
    with pytest.raises(AccelcalError, match="different serials"):
        compare(make_record(), make_record(serial="SN-2"))
    with pytest.raises(AccelcalError, match="different methods"):
        compare(make_record(), make_record(method="tumble/fourier"))


def test_repeatability_is_the_sample_sd_of_the_records():
    recs = records(5)
    rows = {r["quantity"]: r for r in repeatability(recs)}
    k_i = np.array([r.estimates[1] for r in recs])
    f = rows["bias repeatability (K_F)"]
    bias = np.array([r.estimates[0] / r.estimates[1] for r in recs]) * 1e6
    assert f["estimate"] == pytest.approx(np.std(bias, ddof=1), rel=1e-9)
    assert f["low"] < f["estimate"] < f["high"]
    assert rows["scale-factor repeatability (K_I)"]["estimate"] == pytest.approx(
        np.std(k_i / k_i.mean(), ddof=1) * 1e6, rel=1e-9)
    with pytest.raises(AccelcalError, match="at least 3"):
        repeatability(recs[:2])


def test_cli_compare_and_repeatability_from_the_store(tmp_path, capsys):
    paths = []
    for i, rec in enumerate(records(3)):
        paths.append(tmp_path / f"r{i}.json")
        rec.save(paths[-1])
    other = tmp_path / "other.json"
    make_record(serial="SN-2").save(other)
    code, out, _ = run_cli(["acceptance", "compare", paths[0], paths[1], "--format", "csv"],
                           capsys)
    assert code == 0
    assert out.splitlines()[0].startswith("quantity,before,after,estimate,std,unit,En")
    code, _, err = run_cli(["acceptance", "compare", paths[0], other], capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    db = tmp_path / "store.sqlite"
    assert run_cli(["records", "add", *paths[:2], "--db", db], capsys)[0] == 0
    code, _, err = run_cli(["acceptance", "repeatability", "--serial", "SN-1", "--db", db],
                           capsys)
    assert code == 2
    assert "at least 3" in err
    assert run_cli(["records", "add", paths[2], "--db", db], capsys)[0] == 0
    code, out, _ = run_cli(["acceptance", "repeatability", "--serial", "SN-1", "--db", db,
                            "--format", "json"], capsys)
    assert code == 0
    assert '"n": 3' in out


def test_cli_compare_with_a_guarded_spec(tmp_path, capsys):
    one, two, spec = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "s.toml"
    make_record(date="2026-01-01T00:00:00+00:00").save(one)
    make_record(date="2026-02-01T00:00:00+00:00", shift=5e-6).save(two)
    spec.write_text('[[limit]]\nquantity = "K_F"\nlower = -5\nupper = 5\nunit = "ug"\n')
    code, out, err = run_cli(["acceptance", "compare", one, two, "--spec", spec,
                              "--decision-rule", "guarded", "--format", "json"], capsys)
    assert code == 0
    import json

    (k_f,) = [r for r in json.loads(out) if r["quantity"] == "K_F"]
    assert k_f["decision"] == "inconclusive"  # 3.85 ug inside 5 ug but within U of it
    assert "guarded rule" in err
    code, _, err = run_cli(["acceptance", "compare", one, two, "--decision-rule", "lax"], capsys)
    assert code == 2


def test_a_noise_record_gives_the_in_run_stability_beside():
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.results import Estimate

    est = Estimate(("N", "B", "K"), np.array([2e-5, 5e-6, 2e-7]), np.diag([1e-12, 1e-14, 1e-16]),
                   {"N": "g*sqrt(s)", "B": "g", "K": "g/sqrt(s)"}, "noise/ieee952-fit")
    noise = CalibrationRecord.from_estimate(est, serial="SN-1", date="2026-03-01T00:00:00+00:00")
    rows = repeatability([*records(3), noise])
    assert rows[-1]["quantity"] == "in-run stability (B)"
    assert rows[-1]["estimate"] == pytest.approx(5.0)
    assert rows[-1]["unit"] == "ug"
    assert all(r["n"] == 3 for r in rows[:-1])
    with pytest.raises(AccelcalError, match="at least 3"):
        repeatability([*records(2), noise])


def test_a_known_correlation_shrinks_the_shift_uncertainty():
    one = make_record(date="2026-01-01T00:00:00+00:00")
    two = make_record(date="2026-02-01T00:00:00+00:00", shift=5e-6)
    free, tied = compare(one, two)[0], compare(one, two, correlation=0.5)[0]
    assert tied["std"] == pytest.approx(free["std"] / math.sqrt(2.0), rel=1e-9)  # equal u
    with pytest.raises(AccelcalError, match="correlation"):
        compare(one, two, correlation=1.5)
