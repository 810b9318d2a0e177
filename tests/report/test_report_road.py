"""One road to a report: ``accelcal report RECORDS`` gives the demo's sections for them."""

import json
import re
import shutil

import numpy as np
import pytest

from accelcal.demo import SERIALS
from accelcal.report.inputs import report_sections
from accelcal.report.sections import reduction_sections
from helpers.cli import refused, run_cli

pytestmark = pytest.mark.xdist_group("demo")  # the shared campaign (tests/report/conftest.py)


@pytest.fixture(scope="module")
def campaign(demo_campaign):
    """The demo's campaign: every method that writes calibration records."""
    return demo_campaign.result


def _demo_sections(result):
    return [s for o in result.outcomes for s in reduction_sections(o.reduction, o.records,
                                                                   **o.context)]


@pytest.fixture(scope="module")
def demo_sections(campaign):
    """The campaign's report sections, as the demo builds them (drawn once)."""
    return _demo_sections(campaign)


def _same_section(a, b):
    assert a.title == b.title
    assert a.summary == b.summary
    assert a.rows == b.rows
    assert a.notes == b.notes
    assert a.errata == b.errata
    assert [f.title for f in a.figures] == [f.title for f in b.figures]
    assert [f.caption for f in a.figures] == [f.caption for f in b.figures]
    assert (a.record is None) == (b.record is None)
    if a.record is not None:
        assert a.record.names == b.record.names
        np.testing.assert_array_equal(a.record.estimates, b.record.estimates)
        assert a.record.notes == b.record.notes


def test_report_of_the_records_is_the_demos_report(campaign, demo_sections):
    demo = demo_sections
    road = report_sections(campaign.records)  # inputs found in the campaign's data/
    assert [s.title for s in road] == [s.title for s in demo]
    for a, b in zip(road, demo, strict=True):
        _same_section(a, b)
    assert sum(len(s.figures) for s in road) >= 8
    assert any(s.errata for s in road)
    # the engineering column is filled (µg, ppm, arcsec ...)
    assert any("\n(" in str(v) for s in road for row in s.rows or () for v in row.values())


def test_report_command_draws_the_figures(campaign, capsys, tmp_path):
    head = [p for p in campaign.records if p.name.endswith("-head.json")]
    out = tmp_path / "r.html"
    code, _, err = run_cli(["report", *head, "--out", out], capsys)
    assert code == 0, err
    html = out.read_text(encoding="utf-8")
    assert html.count("<figure") == len(campaign.outcomes[0].reduction.figures()) > 0
    assert "No figures" not in html
    assert "Corrections to the published method" in html
    assert html.count("<h2>") == 3  # the summary, the test's section, the appendix
    assert html.count('<div id="sA.') == 4  # the four sensors' records, in the appendix


def test_inputs_next_to_the_record_or_given_with_data(campaign, tmp_path):
    head = [p for p in campaign.records if p.name.endswith("-head.json")]
    alone = tmp_path / "alone"
    alone.mkdir()
    for p in head:
        shutil.copy(p, alone)
    copies = sorted(alone.glob("*.json"))
    (missing,) = report_sections(copies[:1])
    assert missing.notes[0].startswith("No figures: input file(s) indexing_head.csv")
    assert not missing.figures
    assert missing.summary.startswith("Reported from the calibration record(s) alone")
    assert missing.title == f"{SERIALS[0]}: Indexing head (dividing-head/joint)"
    assert "--data" in missing.notes[0]
    found = report_sections(copies, search=[campaign.out / "data"])
    demo = reduction_sections(campaign.outcomes[0].reduction, campaign.outcomes[0].records,
                              **campaign.outcomes[0].context)
    for a, b in zip(found, demo, strict=True):
        _same_section(a, b)
    shutil.copy(campaign.out / "data" / "indexing_head.csv", alone)
    assert report_sections(copies)[0].figures  # found next to the record


def test_one_sensor_of_a_head_run_keeps_the_overview(campaign):
    one = next(p for p in campaign.records if p.name == f"{SERIALS[1]}-head.json")
    sections = report_sections([one])
    assert [s.record.serial for s in sections if s.record is not None] == [SERIALS[1]]
    overview = sections[0]
    assert overview.figures
    heads = list(overview.rows[0])
    assert heads == ["coefficient", "unit", "U1", f"{SERIALS[1]} (U2)", "U3", "U4"]


def test_a_record_the_files_do_not_reproduce_is_reported_without_figures(campaign, tmp_path):
    src = next(p for p in campaign.records if p.name.endswith("-noise.json"))
    data = json.loads(src.read_text(encoding="utf-8"))
    data["coefficients"][0]["estimate"] *= 1.001
    changed = tmp_path / "records" / src.name
    changed.parent.mkdir()
    changed.write_text(json.dumps(data), encoding="utf-8")
    (section,) = report_sections([changed], search=[campaign.out / "data"])
    assert not section.figures
    assert "do not give the record's estimates" in section.notes[0]
    assert section.record.estimates[0] == data["coefficients"][0]["estimate"]


def test_other_accelcal_files_are_named_in_one_line(campaign, capsys, tmp_path):
    from accelcal.defaults import default_model
    from accelcal.io.model_file import dumps, model_to_dict

    model = tmp_path / "model.json"
    model.write_text(dumps(model_to_dict(default_model())), encoding="utf-8")
    refused(["report", model, "--out", tmp_path / "r.html"], capsys,
            "model.json is an error model file", "report takes calibration records")
    reduction = tmp_path / "reduction.json"
    reduction.write_text("{}", encoding="utf-8")
    refused(["report", reduction, "--out", tmp_path / "r.html"], capsys,
            "reduction.json is not a calibration record")
    kalibr = tmp_path / "imu.yaml"
    kalibr.write_text("accelerometer_noise_density: 2.0e-4\n", encoding="utf-8")
    refused(["report", kalibr, "--out", tmp_path / "r.html"], capsys,
            "imu.yaml is not JSON: it is a Kalibr IMU noise file", "--record")
    refused(["report", campaign.out / "records.sqlite", "--out", tmp_path / "r.html"], capsys,
            "records.sqlite is not JSON: it is a records store", "--history --db")
    refused(["report", campaign.out / "data" / "triad.csv", "--out", tmp_path / "r.html"],
            capsys, "record file of data (kind 'triad')", "--record")
    refused(["report", campaign.records[0], "--out", tmp_path / "r.html", "--data",
             tmp_path / "nowhere"], capsys, "--data", "not a directory")
    assert not (tmp_path / "r.html").exists()


def test_a_reductions_json_output_is_reported_without_figures(campaign, capsys, tmp_path):
    reduction = tmp_path / "reduction.json"
    reduction.write_text(campaign.outcomes[0].reduction.to_json(), encoding="utf-8")
    out = tmp_path / "r.html"
    code, _, err = run_cli(["report", reduction, "--out", out], capsys)
    assert code == 0, err
    html = out.read_text(encoding="utf-8")
    assert "reduction.json: Indexing head" in html
    assert "No figures: a reduction&#39;s JSON output holds its coefficients" in html
    assert "K_F+K_OO" in html
    assert " µg)" in html
    assert "<figure" not in html


def test_triad_calibration_file_gets_its_section(campaign, capsys, tmp_path):
    from accelcal.methods.triad.model import TriadCalibration

    cal = TriadCalibration(bias=(310.0, -245.0, 120.0), scale=(6e-4, 6.02e-4, 5.95e-4),
                           angles=(1e-3, -2e-3, 5e-4), input_unit="counts")
    path = tmp_path / "cal.json"
    cal.save(path)
    imucal = tmp_path / "imucal.json"
    imucal.write_text(json.dumps(cal.to_imucal()), encoding="utf-8")
    refused(["report", imucal, "--out", tmp_path / "r.html"], capsys,
            "imucal.json is a triad calibration in imucal's layout", "--out")
    (section,) = report_sections([path])
    assert section.title == "cal.json: triad calibration"
    values = {r["parameter"]: r["value"] for r in section.rows}
    assert values["b_y"] == -245.0
    assert values["a_zy"] == -2e-3
    field = {r["parameter"]: r["in field units"] for r in section.rows}
    assert field["a_zy"] == "-2000 µrad"
    assert field["b_x"] == f"{310.0 * 6e-4 / 9.80665 * 1e6:.7g} µg"  # b_x s_x in g
    out = tmp_path / "r.html"
    from accelcal.io.calibration_record import CalibrationRecord

    triad = next(p for p in campaign.records if CalibrationRecord.load(p).serial == "IMU-0001")
    code, _, err = run_cli(["report", path, triad, "--out", out], capsys)
    assert code == 0, err
    html = out.read_text(encoding="utf-8")
    assert "cal.json: triad calibration" in html
    assert "IMU-0001" in html


def test_the_records_numbers_are_reported_bit_for_bit(campaign, tmp_path):
    # a record whose estimate differs from the re-reduced one by rounding (another BLAS)
    src = next(p for p in campaign.records if p.name.endswith("-vibrafuge.json"))
    data = json.loads(src.read_text(encoding="utf-8"))
    value = data["coefficients"][0]["estimate"] * (1 + 1e-12)
    data["coefficients"][0]["estimate"] = value
    moved = tmp_path / "records" / src.name
    moved.parent.mkdir()
    moved.write_text(json.dumps(data), encoding="utf-8")
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.report.rebuild import rebuild

    record = CalibrationRecord.load(moved)
    built = rebuild([record], [moved], [campaign.out / "data"])
    assert not built.unavailable  # the files reproduce the record to rounding
    name = data["coefficients"][0]["name"]
    again = next(o for o in campaign.outcomes if o.tag == "vibrafuge").reduction
    assert again.value(name) != value
    assert built.reduction.value(name) == value  # the record's number, not the re-reduced one
    np.testing.assert_array_equal(built.reduction.sensors[0].covariance, record.covariance)


def test_every_demo_method_has_a_rebuild():
    from accelcal.catalog import demo_methods
    from accelcal.methods import package
    from accelcal.report.rebuild import family_of

    assert all(callable(package(m.family).from_inputs) for m in demo_methods())
    assert family_of("ieee952-fit") == "noise"
    assert family_of("dividing-head/joint") == "dividing-head"
    assert family_of("transverse-2w") == "transverse"
    assert family_of("made-up/x") is None


def test_records_of_the_commands_defaults_get_their_figures(capsys, tmp_path, monkeypatch):
    # the gravity-norm route as `triad calibrate` runs it: the factor chosen by the residual
    monkeypatch.chdir(tmp_path)
    for args in (["triad", "simulate", "--out", "t.csv", "--positions", "18"],
                 ["triad", "calibrate", "t.csv", "--orientations", "unknown", "--out", "c.json",
                  "--record", "norm.json", "--serial", "T1", "--operator", "A. Person"]):
        code, _, err = run_cli(args, capsys)
        assert code == 0, err
    (section,) = report_sections(["norm.json"])
    assert not section.notes[0].startswith("No figures"), section.notes[0]
    assert section.figures
    assert section.record.operator == "A. Person"


def test_a_record_given_twice_is_reported_once(campaign, tmp_path):
    src = next(p for p in campaign.records if p.name.endswith("-vibrafuge.json"))
    copy = tmp_path / "copy.json"
    shutil.copy(src, copy)
    (section,) = report_sections([src, copy, src])
    assert section.figures


@pytest.mark.slow
def test_every_figure_axis_has_a_unit_and_no_offset(campaign):
    """Every labelled axis of every figure of the demo's tests states its unit in
    parentheses (a categorical axis, labelled by its ticks, excepted), and no axis
    carries offset or scale text ("+1.298", "1e-6") once drawn as the report draws it."""
    from accelcal.plotting.ticks import no_offset

    checked = 0
    for outcome in campaign.outcomes:
        for stem, _title, fig, _caption in outcome.reduction.figures(**outcome.context):
            no_offset(fig)
            fig.draw_without_rendering()
            for ax in fig.axes:
                if ax.name == "polar":
                    continue
                for axis, label, shared in (
                        (ax.xaxis, ax.get_xlabel(), ax.get_shared_x_axes().get_siblings(ax)),
                        (ax.yaxis, ax.get_ylabel(), ax.get_shared_y_axes().get_siblings(ax))):
                    assert axis.get_offset_text().get_text() == "", (stem, label)
                    ticks = [t.get_text() for t in axis.get_ticklabels() if t.get_text()]
                    categorical = bool(ticks) and not ticks[0].lstrip("−-")[:1].isdigit()
                    if not label and len(shared) > 1:
                        continue  # labelled once, on the axes it shares with
                    assert re.search(r"\([^()]+\)\s*$", label) or categorical, (stem, label)
                checked += 1
    assert checked >= 20


def test_the_demo_sections_render_in_field_units_with_readable_dates(demo_sections):
    from accelcal.report import render_report

    html = render_report(demo_sections, title="road", generated="2026-11-26T14:03:27+00:00")
    assert html.index('<section id="summary">') < html.index('<section id="s1">')
    summary = html[html.index('<table class="results">'):]
    summary = summary[:summary.index("</table>")]
    rows = re.findall(r"<tr><td><strong>(.*?)</strong>", summary)
    assert rows == [*SERIALS, "IMU-0001"]
    for unit in ("µg", "ppm", "µrad", "µg/g²", "µg/°C", "ppm/°C", "µg/√Hz", "µg/count"):
        assert unit in summary, unit
    for table in re.findall(r'<table class="coef">.*?</table>', html, flags=re.S):
        for row in re.findall(r"<tr>(.*?)</tr>", table[table.index("<tbody>"):], flags=re.S):
            cells = re.findall(r"<td[^>]*>(.*?)</td>", row, flags=re.S)
            assert cells[-1].strip(), row  # the field-units column is never empty
    assert not re.search(r"\d{4}-\d\d-\d\dT\d\d:\d\d", html)  # no raw time stamps
    assert not re.search(r"(?<![A-Za-z])(ug|degC)(?![A-Za-z])|\+-", html)  # notes as tables
    main = html[:html.index('<section id="appendix">')]
    # one per one-sensor test (the frequency response's comparison and fit are two), none
    # repeated
    assert main.count('<table class="coef">') == 12
    assert main.count('<table class="wide">') == 1  # the head's overview


def test_report_with_a_lab_file_states_the_records_budgets(campaign, capsys, tmp_path):
    from accelcal.budget.lab import load_lab
    from accelcal.report.budgets import record_budgets
    from accelcal.report.inputs import read_input
    from accelcal.report.summary import summary_rows
    from helpers.paths import ROOT

    head = [p for p in campaign.records if p.name.endswith("-head.json")]
    lab = ROOT / "examples" / "lab.toml"
    out = tmp_path / "r.html"
    code, _, err = run_cli(["report", *head, "--out", out, "--lab", lab], capsys)
    assert code == 0, err
    html = out.read_text(encoding="utf-8")
    assert 'id="budgets"' in html  # the annex
    assert "head_angle" in html
    assert "local_gravity" in html
    method = campaign.outcomes[0].reduction.method
    made = record_budgets(head, load_lab(lab))
    assert set(made) == {(s, method) for s in SERIALS}
    records = [read_input(p) for p in head]
    with_budget = summary_rows(records, made)[0]["cells"]["bias"][0].expanded
    alone = summary_rows(records)[0]["cells"]["bias"][0].expanded
    assert with_budget != alone
    assert with_budget.endswith(")")
    # the budget's own U and k, in the field's unit (the budget states U in µg)
    from accelcal.formatting import format_std

    (first,) = [b for b in made[(SERIALS[0], method)]
                if b["coefficient"] in ("K_F", "K_F+K_OO") and b.get("sensor", 0) == 0]
    assert first["unit"] in ("µg", "ug")
    assert with_budget == f"{format_std(first['U'])} µg (k={first['k']:.3g})"
    assert with_budget in html
    plain = run_cli(["report", *head, "--out", tmp_path / "p.html"], capsys)
    assert plain[0] == 0
    text = (tmp_path / "p.html").read_text(encoding="utf-8")
    assert 'id="budgets"' not in text
    assert alone in text
    assert with_budget not in text
