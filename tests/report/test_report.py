"""HTML reports: content, escaping, atomic writing, and a look in headless Chromium."""

import re

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.plotting import new_figure
from accelcal.report import Figure, Section, figure_svg, format_std, format_value, render_report
from helpers.records import make_record


@pytest.mark.parametrize(
    ("value", "std", "text"),
    [
        (-8.3e-4, 1e-6, "-0.0008300"),    # digits down to two of the uncertainty
        (1.2993698, 2e-6, "1.2993698"),
        (1.2993698123, 2.5e-7, "1.29936981"),
        (1234.0, 10.0, "1234"),
        (0.0, 1e-6, "0.0"),
        (1.0 / 3.0, float("nan"), "0.3333333"),  # unknown uncertainty: 7 digits
    ],
)
def test_value_formatting(value, std, text):
    assert format_value(value, std) == text


def test_std_formatting():
    assert format_std(2e-6) == "2.0e-06"
    assert format_std(float("nan")) == "not identified"


def _report_html():
    fig = new_figure()
    ax = fig.subplots()
    ax.plot(np.arange(24), np.sin(np.arange(24) / 3), "o-")
    # A serial number holds no path separator (it becomes part of file names), so the
    # closing tag is in the operator.
    rec = make_record(serial="SN-<script>alert(1)", operator="O'Brien & Co </script>")
    return render_report(
        [Section("Indexing head <joint>", rec, summary="24 positions.",
                 notes=("d0 & d1 not separable",), errata=("eq. (22) corrected",),
                 figures=(Figure("Residuals", figure_svg(fig), "of the fit"),)),
         Section("Study", rows=[{"method": "joint", "rms_error": 1.5e-6}])],
        title="Report <1>", generated="2026-11-21T00:00:00+00:00",
    )


def test_report_content_and_escaping():
    html = _report_html()
    assert "<script>" not in html  # user strings are escaped; the page has no script
    assert "SN-&lt;script&gt;alert(1)" in html
    assert "O&#39;Brien &amp; Co &lt;/script&gt;" in html
    assert "Indexing head &lt;joint&gt;" in html
    assert html.count("<svg") == 1
    for needle in ("K_F", "K_I", "K_O", "Expanded (k = 2)", "2.0e-06", "4.0e-06",
                   "Corrections to the published method", "eq. (22) corrected",
                   "d0 &amp; d1 not separable", "first harmonic known", "Correlation"):
        assert needle in html, needle
    assert not re.search(r"(src|href)=\"(https?:)?//", html)  # nothing fetched from outside


def test_report_command_writes_atomically(capsys, tmp_path):
    rec = tmp_path / "r.json"
    make_record().save(rec)
    out = tmp_path / "report.html"
    with pytest.raises(SystemExit) as info:
        main(["report", str(rec), "--out", str(out), "--title", "T"])
    assert info.value.code == 0
    assert "K_I" in out.read_text()
    bad = tmp_path / "bad.json"
    bad.write_text("[]")
    out2 = tmp_path / "report2.html"
    with pytest.raises(SystemExit) as info:
        main(["report", str(rec), str(bad), "--out", str(out2)])
    assert info.value.code == 2
    assert not out2.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json", "r.json", "report.html"]


def test_report_renders_in_headless_chromium(tmp_path, chromium):
    page = tmp_path / "report.html"
    page.write_text(_report_html(), encoding="utf-8")
    shot = tmp_path / "report.png"
    proc = chromium(page.as_uri(), shot, "1100,1400")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert shot.stat().st_size > 20_000  # a rendered page, not a blank one
    console = [line for line in proc.stderr.splitlines() if "CONSOLE" in line]
    assert console == []


def test_history_section_keeps_methods_apart(tmp_path):
    from accelcal.report.sections import history_section
    from accelcal.store import Store

    store = Store(str(tmp_path / "s.sqlite"))
    store.add(make_record(date="2026-01-01T00:00:00+00:00"))
    store.add(make_record(date="2026-02-01T00:00:00+00:00", shift=1e-6))
    store.add(make_record(date="2026-03-01T00:00:00+00:00", method="dividing-head/single"))
    both = history_section(store, "SN-1")
    assert [(r["method"], r["coefficient"]) for r in both.rows][:4] == [
        ("dividing-head/joint", "K_F"), ("dividing-head/joint", "K_I"),
        ("dividing-head/joint", "K_O"), ("dividing-head/single", "K_F")]
    assert both.rows[0]["calibrations"] == 2
    assert both.rows[3]["calibrations"] == 1
    one = history_section(store, "SN-1", method="dividing-head/joint")
    assert "method" not in one.rows[0]
    assert len(one.rows) == 3
    assert history_section(store, "SN-1", method="tumble") is None
