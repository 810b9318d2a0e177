"""The end-to-end demo: simulate, reduce, record, store and report; the report in Chromium."""

import re
import shutil

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.demo import SERIALS, TRIAD_SERIAL, run
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.formats.dividing_head import read_head_record
from accelcal.methods.dividing_head import HeadData, reduce
from accelcal.methods.dividing_head.demo import head_models
from accelcal.rigs.dividing_head import DONG2014_TABLE1, DividingHeadRig, simulate
from accelcal.store import Store

pytestmark = pytest.mark.xdist_group("demo")  # the shared campaign (tests/report/conftest.py)


def test_demo_writes_everything_and_runs_twice(demo_campaign, tmp_path):
    first = demo_campaign.result
    # the second run adds to a copy of the first run's store, in a directory of its own
    db = tmp_path / "store.sqlite"
    for suffix in ("", "-wal"):
        if demo_campaign.db.with_name(demo_campaign.db.name + suffix).exists():
            shutil.copy(demo_campaign.db.with_name(demo_campaign.db.name + suffix),
                        db.with_name(db.name + suffix))
    assert demo_campaign.cpu < 30  # the demo must finish well under a minute; it takes ~7 s of CPU
    assert first.report.is_file()
    assert first.report.stat().st_size > 100_000
    # 4 head, shaker, vibrafuge, noise, thermal, centrifuge; the triad by two routes;
    # the acceptance tests' threshold, input range and turn-ons; the frequency response
    # and its fit
    assert len(first.records) == 16
    assert all(p.is_file() for p in first.records)
    assert all(p.exists() for p in first.data)
    assert len(list((first.out / "data" / "shaker").glob("*.csv"))) == 12
    assert len(first.figures) >= 6
    assert all(p.read_text().startswith("<svg") for p in first.figures)
    records = [CalibrationRecord.load(p) for p in first.records]
    assert sorted({r.serial for r in records}) == [*SERIALS, TRIAD_SERIAL]
    assert {r.method for r in records} == {"dividing-head/joint", "transverse/2w", "vre/identify",
                                           "noise/ieee952-fit", "thermal/wls", "centrifuge/joint",
                                           "triad/known-orientations", "triad/gravity-norm",
                                           "acceptance/threshold", "acceptance/range",
                                           "acceptance/turn-on", "response/comparison",
                                           "response/model-fit"}
    _new_stages_recover_their_truth(first, records)
    # Reduced coefficients agree with the truth within 5 standard uncertainties.
    # The truth, by an independent route: the same reduction of noise-free
    # outputs of an error-free head, which is Dong2014 eq. (5)'s projection of
    # each full model (the default's terms outside eq. (5), e.g. Koo, Kpp, K3
    # and the asymmetry, fold into K_F, K_I, K_II by ~5e-6 V), plus
    # K_O* = K_O + K_I (eta + d0) with eta = 0 and d0 the mean of the simulated
    # head error ([DOMAIN] step 6). The joint reduction removes the head error
    # to second order (~1e-9 V, docs/errata.md), far below the SDs (~1e-6 V).
    d0 = np.mean(read_head_record(first.data[0]).simulation["angle_error_rad"])
    rig = DividingHeadRig.uniform(24, head_models(), noise=0.0)
    ideal = reduce(HeadData.build(rig.positions, simulate(rig).outputs, rig.mounts), "joint",
                   first_harmonic=(0.0, 0.0))
    head = {r.serial: r for r in records if r.method == "dividing-head/joint"}
    for serial, est in zip(SERIALS, ideal.sensors, strict=True):
        truth = est.values + np.array([0.0, 0.0, est.values[1] * d0, 0.0, 0.0])
        np.testing.assert_array_less(np.abs(head[serial].estimates - truth),
                                     5 * head[serial].std + 1e-9, err_msg=serial)
    assert head["ACC-0002"].estimates[1] == pytest.approx(DONG2014_TABLE1[1]["K_I"], abs=5e-6)
    with Store(str(db)) as store:
        assert len(store.calibrations()) == 16
    # Twice: a new date, so new and distinct records, no duplicate error.
    second = run(tmp_path / "demo2", db=str(db), seed=3, progress=False)
    with Store(str(db)) as store:
        assert len(store.calibrations()) == 32
        assert len(store.calibrations("ACC-0001")) == 22
        history = store.history("ACC-0001", "response/model-fit")
        assert len([r for r in history if r["name"] == "f_3dB"]) == 2  # the bandwidth's
        history = store.history("ACC-0001", "response/comparison")
        assert len([r for r in history if r["name"] == "S(80 Hz)"]) == 2
    assert second.record_ids != first.record_ids
    html = second.report.read_text(encoding="utf-8")
    assert "calibration history by dividing-head/joint" in html
    assert html.count("<svg") == len(second.figures)
    _report_command_adds_history_from_the_store(first, str(db), tmp_path)


def _report_command_adds_history_from_the_store(first, db, tmp_path):
    """``accelcal report REC --history --db DB`` on a store holding two demo runs (checked on
    the store of the test above: each demo run costs seconds)."""
    out = tmp_path / "r.html"
    with pytest.raises(SystemExit) as exc:
        main(["report", str(first.records[0]), "--out", str(out), "--history", "--db", db])
    assert exc.value.code == 0
    html = out.read_text(encoding="utf-8")
    assert "ACC-0001: calibration history by dividing-head/joint" in html
    assert "2 stored calibration(s)" in html
    with pytest.raises(SystemExit) as exc:
        main(["report", str(first.records[0]), "--out", str(tmp_path / "x.html"), "--db", db])
    assert exc.value.code == 2
    assert not (tmp_path / "x.html").exists()


def _within(record, name: str, truth: float) -> None:
    """|estimate - truth| below the stated SD times the two-sided 1 - 1e-7 point of
    Student's t for the record's dof (the normal's 5.33 where it is None: noise given):
    a correct reduction fails this once in 1e7 values; 18 triad positions leave 9 dof,
    where |z| > 5 happens once in 1,400."""
    from scipy import stats

    i = record.names.index(name)
    k = stats.t.ppf(1 - 5e-8, record.dof) if record.dof else stats.norm.ppf(1 - 5e-8)
    assert abs(record.estimates[i] - truth) < k * record.std[i], (record.method, name)


def _new_stages_recover_their_truth(result, records):
    """The still recording's N and K, the thermal test's first-order temperature
    coefficients, the centrifuge's K2 and K3, the triad's nine parameters and the frequency
    response's S0, fn and zeta agree with
    the truth the simulators wrote into the data files (:func:`_within`)."""
    from accelcal.io.formats import acceptance as steps_format
    from accelcal.io.formats import centrifuge, noise, response, thermal, triad

    still = next(p for p in result.data if p.name.startswith("still"))
    truth = noise.read(still).metadata["true"]
    (fit,) = [r for r in records if r.method == "noise/ieee952-fit"]
    for name in ("N", "K"):
        _within(fit, name, truth[name])
    chamber = thermal.read(next(p for p in result.data if p.name.startswith("thermal")))
    true_tc = chamber.metadata["true_model"]["temperature"]["coefficients"]
    (tc,) = [r for r in records if r.method == "thermal/wls"]
    for name in ("K0_T1", "K1_T1"):
        _within(tc, name, true_tc[name])
    arm = centrifuge.read(next(p for p in result.data if p.name == "centrifuge.csv"))
    true_model = arm.metadata["simulation"]["true_model"]
    (spun,) = [r for r in records if r.method == "centrifuge/joint"]
    for name in ("K2", "K3"):
        _within(spun, name, true_model[name])
    shaken = response.read(next(p for p in result.data if p.name.startswith("response")))
    (fitted,) = [r for r in records if r.method == "response/model-fit"]
    for name, key in (("S0", "S0"), ("fn", "fn_hz"), ("zeta", "zeta")):
        _within(fitted, name, shaken.metadata["true"][key])
    cal = triad.read(next(p for p in result.data if p.name.startswith("triad")))
    params = cal.metadata["true_calibration"]["parameters"]
    for rec in (r for r in records if r.method.startswith("triad/")):
        for name in rec.names:
            _within(rec, name, params[name])
    first = next(p for p in result.data if p.name == "acceptance-threshold.csv")
    steps = {n: steps_format.read(first.with_name(n))
             for n in ("acceptance-threshold.csv", "acceptance-range.csv")}
    (threshold,) = [r for r in records if r.method == "acceptance/threshold"]
    assert threshold.estimates[0] == pytest.approx(
        steps["acceptance-threshold.csv"].metadata["true_threshold_g"])
    (ranged,) = [r for r in records if r.method == "acceptance/range"]
    neg, pos = steps["acceptance-range.csv"].metadata["true_range_g"]
    _within(ranged, "range_pos", pos)
    _within(ranged, "range_neg", -neg)


def test_demo_report_renders_in_headless_chromium(demo_campaign, tmp_path, chromium):
    result = demo_campaign.result
    shot = tmp_path / "report.png"
    proc = chromium(result.report.resolve().as_uri(), shot, "1200,1800", "--hide-scrollbars")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [line for line in proc.stderr.splitlines() if "CONSOLE" in line] == []
    # The first screen is not blank: its pixels vary (tables, two figures).
    from PIL import Image

    pixels = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert pixels.shape == (1800, 1200)
    assert pixels.std() > 20
    # What a reader must find: coefficient tables with uncertainties, figures.
    html = result.report.read_text(encoding="utf-8")
    assert len(re.findall(r"<table class=\"coef\">", html)) == 16
    assert "Expanded (k = 2)" in html
    assert "± " in html
    assert "Corrections to the published method" in html
    assert "docs/errata.md" in html
    # Self-contained: no script, no linked resource (SVG namespace URIs are names only).
    assert "<script" not in html
    assert "<link" not in html
    assert not re.search(r"""(src|href)=["']?(https?:|//)""", html)
    _laid_out_for_readers(html, tmp_path)


MEASURE = """<script>addEventListener('load', () => {
  let wrapped = [];
  for (const td of document.querySelectorAll('td')) {
    const walk = document.createTreeWalker(td, NodeFilter.SHOW_TEXT);
    for (let n = walk.nextNode(); n; n = walk.nextNode()) {
      if (!n.textContent.trim() || n.textContent.includes('\\n')) continue;
      const r = document.createRange(); r.selectNodeContents(n);
      const tops = new Set(Array.from(r.getClientRects()).map(x => Math.round(x.top)));
      if (tops.size > 1) wrapped.push(n.textContent);
    }
  }
  const pre = document.createElement('pre'); pre.id = 'measured';
  pre.textContent = JSON.stringify({height: document.documentElement.scrollHeight,
    summaryBottom: document.querySelector('#summary table').getBoundingClientRect().bottom,
    wrapped: wrapped});
  document.body.appendChild(pre);
});</script>"""
"""Measures the page once laid out: its height, where the summary table ends, and every
text of a table cell that the browser broke over more than one line."""


def _laid_out_for_readers(html, tmp_path):
    """The demo's report in Chromium at 1200 x 1000 px: the summary table ends within the
    first screen, no number in a table cell is wrapped, and the page is far shorter than
    the 32,757 px of the report before the summary and the appendix (seed 1)."""
    import json
    import shutil
    import subprocess

    page = tmp_path / "measured.html"
    page.write_text(html.replace("</body>", MEASURE + "</body>"), encoding="utf-8")
    proc = subprocess.run(
        [shutil.which("chromium"), "--headless", "--no-sandbox", "--disable-gpu",
         f"--user-data-dir={tmp_path / 'measure-profile'}", "--window-size=1200,1000",
         "--virtual-time-budget=5000", "--dump-dom", page.as_uri()],
        capture_output=True, text=True, timeout=120, check=False)
    found = re.search(r'<pre id="measured">(.*?)</pre>', proc.stdout, flags=re.S)
    assert found, proc.stderr[-2000:]
    measured = json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&"))
    assert measured["summaryBottom"] < 1000
    assert measured["wrapped"] == []
    # 32,757 px before, for the same campaign; 24,118 px with the frequency response's
    # budgets in the annex (each step's magnitude and phase, folded under one line each)
    assert measured["height"] < 25_000


def test_demo_command_prints_where_everything_is_and_never_touches_the_users_store(
        tmp_path, capsys, monkeypatch):
    # The lab's store (by $ACCELCAL_DB or the XDG default) must stay untouched: the
    # demo's simulated calibrations go to a store inside its output directory.
    lab_store = tmp_path / "lab.sqlite"
    monkeypatch.setenv("ACCELCAL_DB", str(lab_store))
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    with pytest.raises(SystemExit) as exc:
        main(["demo", "--out", str(tmp_path / "d"), "--seed", "1"])
    assert exc.value.code == 0
    out = capsys.readouterr()
    assert f"report:  {tmp_path / 'd' / 'report.html'}" in out.out
    assert "records:" in out.out
    assert "seed:    1" in out.out
    assert "writing the report" in out.err  # the progress bar's last stage, on stderr
    assert not lab_store.exists()
    assert not (tmp_path / "xdg").exists()
    own = tmp_path / "d" / "records.sqlite"
    assert own.is_file()
    (store_line,) = [line for line in out.out.splitlines() if line.startswith("store:")]
    assert str(own) in store_line
    with Store(str(own)) as store:
        assert len(store.calibrations()) == 16
