"""The report's layout for people who read calibrations: summary first, field units, appendix."""

import re

import numpy as np
import pytest

from accelcal.formatting import format_date, format_text, format_unit
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.report import Section, render_report
from accelcal.report.summary import GROUPS, summary_rows
from accelcal.report.units import field_values, quantity_of, record_field_values
from accelcal.results import Estimate
from helpers.records import make_record


def _record(names, values, units, *, serial="SN-9", method="thermal/wls", std=1e-6,
            date="2026-11-26T14:03:27+00:00", notes=()):
    est = Estimate(tuple(names), np.array(values, dtype=float),
                   np.diag(np.full(len(names), std**2)), dict(zip(names, units, strict=True)),
                   method, notes=notes)
    return CalibrationRecord.from_estimate(est, serial=serial, date=date, operator="A. Person")


def _tbody_rows(html: str, table_class: str) -> list[str]:
    table = html[html.index(f'<table class="{table_class}">'):]
    table = table[:table.index("</table>")]
    body = table[table.index("<tbody>"):]
    return re.findall(r"<tr>.*?</tr>", body, flags=re.S)


def test_summary_table_comes_first_with_a_row_per_serial_in_field_units():
    recs = [make_record(serial="SN-1"), make_record(serial="SN-2", shift=1e-6),
            make_record(serial="SN-1", method="dividing-head/four")]
    html = render_report([Section(f"{r.serial} {r.method}", r) for r in recs], title="T",
                         generated="2026-11-26T14:03:27+00:00")
    first = html.index("<section")
    assert html[first:].startswith('<section id="summary">')
    assert html.index('<table class="results">') < html.index('<table class="coef">')
    rows = _tbody_rows(html, "results")
    assert len(rows) == 2  # two serial numbers, SN-1 tested twice
    assert "SN-1" in rows[0]
    assert "SN-2" in rows[1]
    assert "U (k=2)" in html
    for row in rows:
        assert " µg" in row
        assert " ppm" in row
        assert " µrad" in row
    # K_F = -8.3e-4 V over K_I = 1.2993698 V/g is -638.77 µg; U = 2 x 1e-6 V / K_I = 1.5 µg
    assert "-638.77 µg" in rows[0]
    assert "1.5 µg" in rows[0]


def test_summary_lines_are_the_estimates_with_two_standard_uncertainties():
    rec = _record(["K0_T1", "K1_T1", "K0_hyst"], [8e-6, -25e-6, 1e-5],
                  ["g/degC", "1/degC", "g"], std=1e-7)
    (row,) = summary_rows([rec])
    other = row["cells"]["other"]
    assert [line.coefficient for line in other] == ["K0_T1", "K1_T1"]  # the family's keys
    assert other[0].estimate == "8.00 µg/°C"
    assert other[0].expanded == "0.20 µg/°C"
    assert other[1].expanded == "0.20 ppm/°C"


def test_a_budgets_u_and_k_replace_the_default():
    rec = make_record(serial="SN-1")
    budget = {("SN-1", rec.method): [{
        "coefficient": "K_F", "estimate": -8.3e-4, "unit": "V", "u_c": 1.5e-6, "nu_eff": 40,
        "k": 2.3, "U": 3.45e-6, "correlated": False,
        "rows": [{"quantity": "local gravity", "estimate": 9.80665, "u": 1e-5, "unit": "m/s^2",
                  "distribution": "normal", "sensitivity": 1e-4, "contribution": 1e-9,
                  "dof": None, "share": 0.01}]}]}
    (row,) = summary_rows([rec], budget)
    bias = row["cells"]["bias"][0]
    assert bias.expanded == "2.7 µg (k=2.3)"  # 3.45e-6 V / 1.2993698 V/g
    assert row["cells"]["scale"][0].expanded == "3.1 ppm"  # no budget: 2 x 2e-6 / K_I
    html = render_report([Section("head", rec)], title="T", budgets=budget)
    assert 'id="budgets"' in html
    assert "local gravity" in html
    assert "1.0 %" in html
    assert "∞" in html
    assert 'id="budgets"' not in render_report([Section("head", rec)], title="T")


def test_every_coefficient_has_field_units():
    rec = _record(["K0_hyst", "K1_hyst", "Kp_hyst", "warmup_tau", "warmup_K0", "N", "K",
                   "K1"], [1e-5, -5e-6, 4e-6, 300.0, -6e-4, 2e-5, 2e-7, 1.3],
                  ["g", "1", "g/g", "s", "g", "g*sqrt(s)", "g/sqrt(s)", "V/g"])
    texts = [fv[0].text() for fv in record_field_values(rec)]
    assert texts[0].endswith(" µg")
    assert texts[1].endswith(" ppm")
    assert texts[2].endswith(" µrad")
    assert texts[3].endswith(" s")
    assert texts[4].endswith(" µg")
    assert texts[5] == "20.0 ± 1.0 µg/√Hz"
    assert texts[6].endswith(" µg/√s")
    assert texts[7] == "1.3000000 V/g ± 0.77 ppm"  # 1e-6 / 1.3, relative
    html = render_report([Section("thermal", rec)], title="T")
    cells = [re.findall(r"<td[^>]*>(.*?)</td>", row, flags=re.S)[-1]
             for row in _tbody_rows(html, "coef")]
    assert len(cells) == 8
    assert all(c.strip() for c in cells)


def test_a_triads_bias_goes_through_its_axis_scale_factor():
    rec = _record(["b_x", "s_x", "a_yz"], [310.0, 6e-4, 2e-3],
                  ["counts", "(m/s^2)/(counts)", "rad"], method="triad/known-orientations")
    bias, scale, angle = (fv[0] for fv in record_field_values(rec))
    assert bias.unit == "ug"
    assert bias.estimate == pytest.approx(310.0 * 6e-4 / 9.80665 * 1e6)
    assert scale.unit == "ug/count"
    assert scale.relative
    assert angle.unit == "urad"
    assert angle.estimate == pytest.approx(2000.0)
    assert quantity_of("K_F+K_OO", "V") == "bias"
    assert quantity_of("K_II-K_OO", "V/g^2") == "second"
    assert field_values("mystery", 3.0, 0.1, "Hz")[0].text() == "3.00 ± 0.10 Hz"


def test_dates_notes_and_units_read_as_printed():
    assert format_date("2026-11-26T14:03:27.123456+00:00") == "2026-11-26 14:03 UTC"
    assert format_date("2026-11-26T16:03:27+02:00") == "2026-11-26 14:03 UTC"
    assert format_date("2026-11-26") == "2026-11-26"
    assert format_date("not a date") == "not a date"
    assert format_text("K3 +-2.4e-07 g/g^3; 8 ug/degC; sqrt(Hz); let us") == \
        "K3 ± 2.4e-07 g/g³; 8 µg/°C; √Hz; let us"
    assert format_unit("g*sqrt(s)") == "g·√s"
    rec = _record(["K0"], [1e-5], ["g"], date="2026-11-26T14:03:27.5+00:00",
                  notes=("bias +- 3 ug at 25 degC",))
    html = render_report([Section("head", rec)], title="T",
                         generated="2026-11-26T15:00:00+00:00")
    assert "2026-11-26 14:03 UTC" in html
    assert "2026-11-26T14:03" not in html
    assert "bias ± 3 µg at 25 °C" in html


def test_errata_and_per_sensor_records_go_to_the_appendix():
    recs = [make_record(serial=f"SN-{k}") for k in (1, 2)]
    sections = [Section("head", rows=[{"coefficient": "K_F"}], notes=("shared note",),
                        errata=("eq. (22) corrected",)),
                *(Section(r.serial, r, notes=("shared note",), appendix=True) for r in recs)]
    html = render_report(sections, title="T")
    appendix = html.index('<section id="appendix">')
    assert html.index("eq. (22) corrected") > appendix
    assert html.index("<h3>Corrections to the published method</h3>") > appendix
    assert html.index('<div id="sA.1">') > appendix
    assert html.count("shared note") == 1  # not repeated in the sensors' records
    assert html.count('<table class="coef">') == 2


def test_history_in_field_units(tmp_path):
    from accelcal.report.sections import history_section
    from accelcal.store import Store

    with Store(str(tmp_path / "s.sqlite")) as store:
        store.add(make_record(date="2026-01-01T00:00:00+00:00"))
        store.add(make_record(date="2026-02-01T00:00:00+00:00", shift=1e-6))
        section = history_section(store, "SN-1")
    rows = {r["coefficient"]: r for r in section.rows}
    # K_F: -8.3e-4 and -8.29e-4 V over K_I ~1.2993708 V/g: mean -638.4 µg, spread 0.54 µg
    assert rows["K_F"]["mean"] == "-638.39 µg"
    assert rows["K_F"]["repeatability (1 σ)"] == "0.54 µg"
    assert rows["K_I"]["mean"] == "1.29937030 V/g"  # to two digits of its 0.54 ppm spread
    assert rows["K_I"]["mean own σ"] == "1.5 ppm"  # 2e-6 V/g of 1.2993703 V/g
    assert "ppm" in section.figures[0].svg  # the scale factor drawn as ppm from its mean


def test_print_css_keeps_figures_and_tables_whole_and_legible():
    html = render_report([Section("head", make_record())], title="T")
    css = html[html.index("<style>"):html.index("</style>")]
    page = re.search(r"@page\s*{([^}]*)}", css).group(1)
    assert "A4" in page
    printed = css[css.index("@media print"):]
    sizes = [float(x) for x in re.findall(r"font-size:\s*([\d.]+)pt", printed)]
    assert sizes
    assert min(sizes) >= 8
    assert not re.search(r"font-size:\s*[\d.]+px", printed)  # print sizes in points only
    assert re.search(r"table, figure\s*{[^}]*break-inside: avoid", printed)
    assert re.search(r"figure svg\s*{[^}]*max-width: 100%", printed)
    # screen: numbers never wrap in a cell
    assert re.search(r"th, td\s*{[^}]*white-space: nowrap", css)


def test_printed_summary_is_one_block_per_serial_that_fits_a_page():
    recs = [make_record(serial="SN-1"), make_record(serial="SN-2", shift=1e-6),
            make_record(serial="SN-1", method="dividing-head/four")]
    html = render_report([Section(f"{r.serial} {r.method}", r) for r in recs], title="T")
    summary = html[html.index('<section id="summary">'):html.index("</section>")]
    table = summary[summary.index('<table class="serials">'):]
    table = table[:table.index("</table>")]
    blocks = re.findall(r"<tbody>(.*?)</tbody>", table, flags=re.S)
    assert len(blocks) == 2  # a block per serial number, SN-1's two tests in one
    assert "SN-1" in blocks[0]
    assert "SN-2" in blocks[1]
    rows = [re.findall(r"<td[^>]*>(.*?)</td>", row, flags=re.S)
            for row in re.findall(r"<tr>(.*?)</tr>", blocks[0], flags=re.S)]
    wide = next(row for row in summary_rows(recs) if row["serial"] == "SN-1")
    lines = [line for key, _ in GROUPS for line in wide["cells"][key]]
    assert len(rows) == len(lines) >= 6  # every key coefficient of both tests, one a row
    for cells, line in zip(rows, lines, strict=True):
        assert cells[1:4] == [line.coefficient, line.estimate, line.expanded]
    # the group's heading on its first row only: bias, then scale factor, ...
    headings = [cells[0] for cells in rows if cells[0]]
    assert headings == [h for key, h in GROUPS if wide["cells"][key]]
    assert "-638.77 µg" in blocks[0]
    css = html[html.index("<style>"):html.index("</style>")]
    screen, printed = css[:css.index("@media print")], css[css.index("@media print"):]
    assert re.search(r"table\.serials\s*{\s*display: none", screen)
    assert re.search(r"\.screen\s*{\s*display: none", printed)  # the wide layout, on screen only
    assert re.search(r"table\.serials\s*{\s*display: table", printed)
    assert re.search(r"table\.serials tbody\s*{[^}]*break-inside: avoid", printed)
    assert 'class="scroll screen"' in summary
