"""Complex estimates (a frequency response's sensitivities) through results, JSON, records,
the store and reports.

The covariance of a complex estimate is that of [Re x1, Im x1, Re x2, ...] (GUM
Supplement 2, JCGM 102:2011 secs. 6.2.1.3 and 9.3); magnitude and phase uncertainties are
its first-order propagation, checked here against a Monte Carlo of the same Gaussian.
"""

import dataclasses
import json
import math

import numpy as np
import pytest
import sqlalchemy as sa

from accelcal.cli import main
from accelcal.errors import AccelcalError
from accelcal.formatting import format_std, pm_polar
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import LabInfo
from accelcal.polar import polar
from accelcal.report import Section, render_report
from accelcal.report.rebuild import with_record_numbers
from accelcal.report.sections import overview_rows
from accelcal.results import Estimate, Reduction
from accelcal.store import SCHEMA_VERSION, Store
from helpers.paths import FIXTURES

INFO = LabInfo(("SN-FR",), "J. Smith", "2026-11-20T09:30:00+00:00")
NAMES = ("S_20Hz", "S_80Hz", "S_320Hz")
VALUES = np.array([1.0012 - 0.0213j, 0.9871 - 0.1702j, -0.3120 - 0.5504j])
"""Three sensitivities (V/g): lagging phase, growing with frequency, one past -90 deg."""


def _covariance() -> np.ndarray:
    """A covariance of [Re, Im] x 3 with Re-Im correlations of +-0.8 and between rows."""
    sd = np.array([2.0e-3, 1.0e-3, 3.0e-3, 4.0e-3, 5.0e-3, 2.5e-3])
    corr = np.eye(6)
    for i, j, r in ((0, 1, 0.8), (2, 3, -0.8), (4, 5, 0.6), (0, 2, 0.3), (1, 5, -0.2)):
        corr[i, j] = corr[j, i] = r
    return corr * np.outer(sd, sd)


def _estimate(**kwargs) -> Estimate:
    return Estimate(NAMES, VALUES, _covariance(), dict.fromkeys(NAMES, "V/g"),
                    "frequency-response/comparison", dof=kwargs.pop("dof", 40), **kwargs)


def _reduction(**kwargs) -> Reduction:
    return Reduction("frequency-response", "frequency-response/comparison",
                     (_estimate(),), dof=40, **kwargs)


# ------------------------------------------------------------------ uncertainty
@pytest.mark.parametrize("k", range(3))
def test_magnitude_and_phase_sds_match_a_monte_carlo_of_the_same_gaussian(k):
    cov = _covariance()
    block = cov[2 * k:2 * k + 2, 2 * k:2 * k + 2]
    n = 200_000
    rng = np.random.default_rng(20261126 + k)
    draws = rng.multivariate_normal([VALUES[k].real, VALUES[k].imag], block, size=n)
    z = draws[:, 0] + 1j * draws[:, 1]
    mc_mag = np.abs(z).std(ddof=1)
    mc_phase = np.angle(z / VALUES[k]).std(ddof=1)  # about the estimate: no wrap at +-pi
    pol = polar(VALUES, cov)
    # The sample SD of n Gaussian draws has relative SD 1/sqrt(2(n-1)) (0.16 % here); allow
    # 4 of them, plus the first-order propagation's own error, O((u/|x|)^2) < 1e-4 here.
    tol = 4 / math.sqrt(2 * (n - 1)) + 1e-4
    assert pol.magnitude_std[k] == pytest.approx(mc_mag, rel=tol)
    assert pol.phase_std[k] == pytest.approx(mc_phase, rel=tol)
    # The Re-Im correlation matters: leaving it out misses the Monte Carlo by far more.
    diagonal = polar(VALUES, np.diag(np.diag(cov)))
    assert abs(diagonal.magnitude_std[k] / mc_mag - 1) > 3 * tol \
        or abs(diagonal.phase_std[k] / mc_phase - 1) > 3 * tol


def test_estimate_and_reduction_accessors_of_a_complex_coefficient():
    est, red = _estimate(), _reduction()
    pol = polar(VALUES, _covariance())
    assert est.is_complex
    assert red.value("S_80Hz") == complex(VALUES[1])
    assert isinstance(red.value("S_80Hz"), complex)
    assert red.std("S_80Hz") == pytest.approx(pol.magnitude_std[1], rel=1e-12)
    np.testing.assert_allclose(est.std, pol.magnitude_std, rtol=1e-12)
    np.testing.assert_array_equal(est.block("S_320Hz"), _covariance()[4:6, 4:6])
    assert red.status("S_20Hz") == "fitted"
    assert red.scale_factor() is None  # a complex estimate defines no scale factor


def test_complex_estimate_needs_the_real_2p_covariance():
    with pytest.raises(ValueError, match=r"covariance \(6, 6\)"):
        Estimate(NAMES, VALUES, np.eye(3), dict.fromkeys(NAMES, "V/g"), "x")
    with pytest.raises(ValueError, match="must be real"):
        Estimate(NAMES, VALUES, np.eye(6) * (1 + 0j), dict.fromkeys(NAMES, "V/g"), "x")


# ------------------------------------------------------------------ rows and JSON
def test_rows_give_magnitude_phase_and_parts():
    rows = _reduction().rows()
    pol = polar(VALUES, _covariance())
    row = rows[2]
    assert row["coefficient"] == "S_320Hz"
    assert row["estimate"] == row["magnitude"] == pytest.approx(abs(VALUES[2]), rel=1e-15)
    assert row["std"] == row["magnitude_std"] == pytest.approx(pol.magnitude_std[2], rel=1e-12)
    assert row["phase_deg"] == pytest.approx(math.degrees(np.angle(VALUES[2])), rel=1e-12)
    assert row["phase_deg"] < -90
    assert row["phase_std_deg"] == pytest.approx(math.degrees(pol.phase_std[2]), rel=1e-12)
    assert (row["real"], row["imag"]) == (VALUES[2].real, VALUES[2].imag)
    assert row["real_std"] == pytest.approx(5.0e-3)
    assert row["imag_std"] == pytest.approx(2.5e-3)
    assert row["eng_unit"] == ""
    assert row["engineering"] == []
    frame = _reduction().to_frame()
    assert frame.loc[("U1", "S_80Hz"), "phase_deg"] == pytest.approx(
        math.degrees(np.angle(VALUES[1])), rel=1e-12)


def test_json_round_trip_is_exact_with_an_unidentified_coefficient():
    values = VALUES.copy()
    values[1] = complex(math.nan, math.nan)
    cov = _covariance()
    cov[2:4, :] = cov[:, 2:4] = math.nan
    est = Estimate(NAMES, values, cov, dict.fromkeys(NAMES, "V/g"), "fr", dof=40)
    red = Reduction("frequency-response", "frequency-response/comparison", (est,), dof=40,
                    provenance={"frequencies_hz": [20, 80, 320]}, notes=("a note",))
    text = red.to_json()
    doc = json.loads(text)
    sensor = doc["sensors"][0]
    assert sensor["complex"] is True
    assert sensor["coefficients"][0]["estimate"] == {"re": 1.0012, "im": -0.0213}
    assert sensor["coefficients"][1]["estimate"] is None
    assert len(sensor["covariance"]) == 6
    back = Reduction.from_json(text)
    np.testing.assert_array_equal(back.estimate.values, values)  # NaN equals NaN here
    np.testing.assert_array_equal(back.estimate.covariance, cov)
    assert back.status("S_80Hz") == "not identifiable"
    assert back.to_json() == text


def test_json_round_trip_of_a_real_reduction_keeps_its_rows():
    est = Estimate(("K_F", "K_I"), [-8.336e-4, 1.2993698], np.diag([1.1e-6, 3.0e-7]) ** 2,
                   {"K_F": "V", "K_I": "V/g"}, "x", dof=19)
    red = Reduction("dividing-head", "dividing-head/single", (est,), dof=19,
                    nominal={"K_I": 1.3})
    back = Reduction.from_json(red.to_json())
    assert back.rows() == red.rows()
    assert "complex" not in red.to_dict()["sensors"][0]
    assert set(red.rows()[0]) == {"sensor", "coefficient", "plain", "estimate", "std", "unit",
                                  "status",
                                  "dof", "eng_estimate", "eng_std", "eng_unit", "engineering"}


@pytest.mark.parametrize(("estimate", "message"), [
    ({"re": 1.0}, r'estimate must be \{"re": number, "im": number\}'),
    ("1+2j", r'estimate must be \{"re": number, "im": number\}'),
])
def test_malformed_complex_json_is_refused_in_one_line(estimate, message):
    doc = _reduction().to_dict()
    doc["sensors"][0]["coefficients"][0]["estimate"] = estimate
    with pytest.raises(AccelcalError, match=message) as info:
        Reduction.from_dict(doc, source="fr.json")
    assert str(info.value).startswith("fr.json: sensors[0]")
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------ records
def test_record_file_round_trip(tmp_path):
    (record,) = _reduction().to_records(INFO)
    assert record.is_complex
    path = tmp_path / "fr.json"
    record.save(path)
    doc = json.loads(path.read_text())
    assert (doc["format_version"], doc["complex"]) == (2, True)
    first = doc["coefficients"][0]
    assert first["estimate"] == {"re": 1.0012, "im": -0.0213}
    assert first["expanded"] == pytest.approx(record.coverage_factor * first["std"])
    assert first["phase_deg"] == pytest.approx(math.degrees(np.angle(VALUES[0])))
    back = CalibrationRecord.load(path)
    np.testing.assert_array_equal(back.estimates, VALUES)
    np.testing.assert_array_equal(back.covariance, _covariance())
    assert back.to_json() == record.to_json()


def test_records_keep_the_re_im_rows_of_the_determined_coefficients():
    values = VALUES.copy()
    values[0] = complex(math.nan, math.nan)
    cov = _covariance()
    cov[0:2, :] = cov[:, 0:2] = math.nan
    est = Estimate(NAMES, values, cov, dict.fromkeys(NAMES, "V/g"), "fr", dof=40)
    (record,) = Reduction("frequency-response", "fr", (est,), dof=40).to_records(INFO)
    assert record.names == NAMES[1:]
    np.testing.assert_array_equal(record.covariance, _covariance()[2:, 2:])


def test_version_2_fixture_reads():
    path = FIXTURES / "calibration_record_v2.json"
    record = CalibrationRecord.load(path)
    doc = json.loads(path.read_text())
    np.testing.assert_array_equal(record.estimates, VALUES)
    np.testing.assert_allclose(record.covariance, _covariance(), rtol=1e-15)
    assert record.std == pytest.approx([c["std"] for c in doc["coefficients"]], rel=1e-12)
    assert np.degrees(record.polar().phase_std) == pytest.approx(
        [c["phase_std_deg"] for c in doc["coefficients"]], rel=1e-12)


def _real_record() -> CalibrationRecord:
    est = Estimate(("K0",), [1e-4], [[1e-12]], {"K0": "g"}, "x")
    (record,) = Reduction("tumble", "tumble-lsq", (est,)).to_records(
        LabInfo(("SN-R",), "", "2026-11-21T09:30:00+00:00"))
    return record


def test_real_records_are_still_format_1():
    doc = json.loads(_real_record().to_json())
    assert doc["format_version"] == 1
    assert "complex" not in doc
    assert set(doc["coefficients"][0]) == {"name", "unit", "estimate", "std", "expanded"}


@pytest.mark.parametrize(("change", "message"), [
    ({"complex": False}, "format_version 2 is that of complex coefficients"),
    ({"format_version": 1}, "format_version 2 is that of complex coefficients"),
    ({"covariance": np.eye(3).tolist()}, r"covariance \(6, 6\)"),
])
def test_inconsistent_complex_records_are_refused(change, message):
    (record,) = _reduction().to_records(INFO)
    doc = json.loads(record.to_json()) | change
    with pytest.raises(AccelcalError, match=message) as info:
        CalibrationRecord.from_json(json.dumps(doc), source="fr.json")
    assert str(info.value).startswith("fr.json: ")
    assert "\n" not in str(info.value)


def test_a_complex_record_refuses_a_covariance_with_re_im_correlation_beyond_one():
    (record,) = _reduction().to_records(INFO)
    doc = json.loads(record.to_json())
    doc["covariance"][0][1] = doc["covariance"][1][0] = 3e-6  # > 2e-3 * 1e-3
    with pytest.raises(AccelcalError, match=r"beyond \+/-1 .* Re\(S_20Hz\), Im\(S_20Hz\)"):
        CalibrationRecord.from_json(json.dumps(doc))


# ------------------------------------------------------------------ store
def test_store_round_trip_beside_real_records(db):
    (complex_record,) = _reduction().to_records(INFO)
    real_record = _real_record()
    with Store(db) as store:
        assert store.schema_version == SCHEMA_VERSION == 5
        ids = store.add_many([real_record, complex_record])
        back = store.record(ids[1])
        history = store.history("SN-FR")
        with store.engine.connect() as conn:
            parts = conn.execute(sa.text(
                "SELECT name, estimate, std, estimate_re, estimate_im FROM coefficients "
                "ORDER BY id")).all()
    np.testing.assert_array_equal(back.estimates, VALUES)
    np.testing.assert_array_equal(back.covariance, _covariance())
    assert back.to_json() == complex_record.to_json()
    assert parts[0][3:] == (None, None)  # the real record's row
    by_name = {p[0]: p for p in parts[1:]}
    assert by_name["S_320Hz"][3:] == (VALUES[2].real, VALUES[2].imag)
    assert by_name["S_320Hz"][1] == pytest.approx(abs(VALUES[2]), rel=1e-15)
    # history and stats follow the magnitude and its standard uncertainty
    assert [h["estimate"] for h in history] == pytest.approx(np.abs(VALUES), rel=1e-15)
    assert [h["std"] for h in history] == pytest.approx(complex_record.std, rel=1e-12)


def test_a_schema_3_store_gains_the_complex_columns(tmp_path):
    db = tmp_path / "old.sqlite"
    with Store(db) as store:
        old_id = store.add(dataclasses.replace(_real_record(), serial="SN-OLD"))
    engine = sa.create_engine(f"sqlite:///{db}")
    with engine.begin() as conn:  # as schema 3 left it: no estimate_re, estimate_im
        conn.execute(sa.text("ALTER TABLE coefficients DROP COLUMN estimate_re"))
        conn.execute(sa.text("ALTER TABLE coefficients DROP COLUMN estimate_im"))
        conn.execute(sa.text("UPDATE schema_info SET version = 3"))
    engine.dispose()
    with Store(db, readonly=True) as store:  # read as it is, without migrating
        assert store.schema_version == 3
        assert [h["estimate"] for h in store.history("SN-OLD")] == [1e-4]
    with Store(db) as store:
        assert store.schema_version == 5
        store.add(_reduction().to_records(INFO)[0])
        assert len(store.history("SN-FR")) == 3
        assert store.record(old_id).to_json() == dataclasses.replace(
            _real_record(), serial="SN-OLD").to_json()
        with store.engine.connect() as conn:
            old = conn.execute(sa.text("SELECT estimate_re, estimate_im FROM coefficients "
                                       f"WHERE calibration_id = {old_id}")).all()
    assert old == [(None, None)]


# ------------------------------------------------------------------ report
def test_report_shows_magnitude_and_phase_with_uncertainties():
    red = _reduction()
    records = red.to_records(INFO)
    table = overview_rows(red, records)
    rows = red.rows()
    expected = pm_polar(rows[1]["magnitude"], rows[1]["magnitude_std"], rows[1]["phase_deg"],
                        rows[1]["phase_std_deg"])
    assert table[1]["estimate ± σ"] == expected
    assert "∠" in expected
    assert expected.endswith("°")
    # the overview (no record) and the sensor's record, in the appendix: one estimate table each
    html = render_report([Section(title="Frequency response", rows=table),
                          Section(title="SN-1", record=records[0], appendix=True)],
                         title="t", generated="2026-11-26T00:00:00+00:00")
    assert "S_80Hz (magnitude)" in html
    assert "S_80Hz (phase)" in html
    assert expected in html
    assert f"<td>{format_std(math.degrees(records[0].polar().phase_std[1]))}</td>" in html
    assert "<th>Re(S_20Hz)</th><th>Im(S_20Hz)</th>" in html
    assert "<td>0.800</td>" in html  # the Re-Im correlation of S_20Hz


def _run(*args) -> int:
    with pytest.raises(SystemExit) as info:
        main(list(args))
    return info.value.code


def test_command_line_stores_and_reports_a_complex_record(capsys, tmp_path):
    fixture = str(FIXTURES / "calibration_record_v2.json")
    db, html = str(tmp_path / "s.sqlite"), tmp_path / "r.html"
    assert _run("records", "add", fixture, "--db", db) == 0
    capsys.readouterr()
    assert _run("records", "history", "SN-FR", "--db", db, "--format", "json") == 0
    history = json.loads(capsys.readouterr().out)
    assert [h["estimate"] for h in history] == pytest.approx(np.abs(VALUES), rel=1e-15)
    assert _run("report", fixture, "--out", str(html), "--history", "--db", db) == 0
    text = html.read_text()
    assert "S_320Hz (phase)" in text
    assert f"{math.degrees(np.angle(VALUES[2])):.2f}" in text


def test_a_rebuilt_reduction_takes_a_complex_records_numbers():
    red = _reduction()
    (record,) = red.to_records(INFO)
    shifted = dataclasses.replace(record, estimates=record.estimates * (1 + 1e-12),
                                  covariance=record.covariance * 1.5)
    rebuilt = with_record_numbers(red, [shifted], [0])
    np.testing.assert_array_equal(rebuilt.estimate.values, shifted.estimates)
    np.testing.assert_array_equal(rebuilt.estimate.covariance, 1.5 * _covariance())
