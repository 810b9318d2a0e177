"""``accelcal certificate``: files written, one-line refusals, budgets kept in the records."""

import json

from accelcal.io.calibration_record import CalibrationRecord
from helpers.certificates import LAB, SPEC, expired_lab, write_inputs
from helpers.cli import assert_one_line_error, run_cli


def test_writes_html_json_and_xml_and_names_them(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    code, out, err = run_cli(["certificate", *paths, "--lab", LAB, "--out", tmp_path / "c.html",
                              "--json", tmp_path / "c.json", "--xml", tmp_path / "c.xml",
                              "--issued", "2026-11-26", "--make", "Example", "--model", "QA",
                              "--received", "2026-11-18", "--country", "DE"], capsys)
    assert code == 0, err
    doc = json.loads((tmp_path / "c.json").read_text(encoding="utf-8"))
    assert out.splitlines()[0] == f"certificate {doc['number']} issued 2026-11-26: SN-1, SN-2"
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "SN-1.json", "SN-2.json", "c.html", "c.json", "c.xml"]
    assert doc["items"][0]["make"] == "Example"
    assert doc["laboratory"]["country"] == "DE"


def test_expired_standard_refuses_with_one_line_and_writes_nothing(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    lab = expired_lab(tmp_path)
    code, _, err = run_cli(["certificate", *paths, "--lab", lab, "--out", tmp_path / "c.html",
                            "--issued", "2026-11-26"], capsys)
    assert_one_line_error(code, err, "daq_gain", "DMM-2025-208", "2020-05-31",
                          "--allow-expired")
    assert not (tmp_path / "c.html").exists()
    code, out, err = run_cli(["certificate", *paths, "--lab", lab, "--out", tmp_path / "c.html",
                              "--issued", "2026-11-26", "--allow-expired"], capsys)
    assert code == 0, err
    assert "warning: issued with expired standard(s): local_gravity, daq_gain" in err
    assert out.startswith("certificate AC-")


def test_spec_and_decision_rule(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    (tmp_path / "spec.toml").write_text(SPEC, encoding="utf-8")
    code, _, err = run_cli(["certificate", *paths, "--lab", LAB, "--out", tmp_path / "c.html",
                            "--json", tmp_path / "c.json", "--issued", "2026-11-26",
                            "--spec", tmp_path / "spec.toml", "--decision-rule", "guarded"],
                           capsys)
    assert code == 0, err
    doc = json.loads((tmp_path / "c.json").read_text(encoding="utf-8"))
    assert doc["decision_rule"] == {"rule": "guarded", "specification": (
        "Acceptance specification, model QA-3000"), "document": "SPEC-0042 rev B"}
    html = (tmp_path / "c.html").read_text(encoding="utf-8")
    assert "Statement of conformity" in html
    assert "guarded acceptance" in html
    assert "inconclusive (in the guard band)" in html
    assert "does not conform" in html


def test_bad_input_is_one_line(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    base = ["certificate", *paths, "--lab", LAB, "--out", tmp_path / "c.html"]
    cases = [
        (["--issued", "2026-13-01"], "issue date"),
        (["--decision-rule", "strict", "--spec", tmp_path / "spec.toml"], "decision rule"),
        (["--spec", tmp_path / "missing.toml"], "specification"),
        (["--number", "../../x y"], "certificate number"),
        (["--data", tmp_path / "SN-1.json"], "--data"),
    ]
    (tmp_path / "spec.toml").write_text(SPEC, encoding="utf-8")
    for extra, needle in cases:
        code, _, err = run_cli([*base, *extra], capsys)
        assert_one_line_error(code, err, needle)
    code, _, err = run_cli(["certificate", *paths, "--lab", tmp_path / "nolab.toml", "--out",
                            tmp_path / "c.html"], capsys)
    assert_one_line_error(code, err, "nolab.toml")
    assert not (tmp_path / "c.html").exists()


def test_keep_budgets_writes_them_into_the_records_and_reissues_identically(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    args = ["certificate", *paths, "--lab", LAB, "--json", tmp_path / "c.json",
            "--issued", "2026-11-26"]
    code, out, err = run_cli([*args, "--out", tmp_path / "a.html", "--keep-budgets"], capsys)
    assert code == 0, err
    assert f"wrote {paths[0]}" in out
    kept = CalibrationRecord.load(paths[0])
    assert kept.budget["lab"]["path"] == "lab.toml"
    assert [s["quantity"] for s in kept.budget["standards"]]
    first = (tmp_path / "c.json").read_bytes()
    code, out, err = run_cli([*args, "--out", tmp_path / "b.html", "--keep-budgets"], capsys)
    assert code == 0, err
    assert f"wrote {paths[0]}" not in out  # the records hold them already
    assert (tmp_path / "a.html").read_bytes() == (tmp_path / "b.html").read_bytes()
    assert (tmp_path / "c.json").read_bytes() == first


def test_store_keeps_the_budget_with_the_record(tmp_path, capsys):
    paths = write_inputs(tmp_path)
    code, _, err = run_cli(["certificate", *paths, "--lab", LAB, "--out", tmp_path / "c.html",
                            "--issued", "2026-11-26", "--keep-budgets"], capsys)
    assert code == 0, err
    from accelcal.store import Store

    with Store(str(tmp_path / "s.sqlite")) as store:
        rid = store.add(CalibrationRecord.load(paths[0]))
        again = store.record(rid)
    assert again.budget == CalibrationRecord.load(paths[0]).budget


def test_pdf_without_weasyprint_is_one_line_and_writes_nothing(tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "weasyprint", None)  # import weasyprint -> ImportError
    paths = write_inputs(tmp_path)
    code, _, err = run_cli(["certificate", *paths, "--lab", LAB, "--out", tmp_path / "c.html",
                            "--pdf", tmp_path / "c.pdf", "--issued", "2026-11-26"], capsys)
    assert_one_line_error(code, err, "WeasyPrint", "pdf")
    assert not (tmp_path / "c.pdf").exists()
    assert not (tmp_path / "c.html").exists()
