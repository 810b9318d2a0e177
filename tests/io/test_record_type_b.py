"""A record keeps each row's Type B part beside its Type A (issue 24, item 2).

A reduction that bounds unestimated terms by priors (here a triad whose axes are the
default pendulous accelerometer, :func:`accelcal.methods.triad.unestimated.with_type_b`)
adds their Type B to the rows' covariance; the record writes each row's share as the
coefficient's optional ``type_b`` key, the store keeps it (in the record's JSON), the
report and ``records show`` print it; a record without the key reads as before.
"""

import json

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import LabInfo
from accelcal.methods.triad import calibrate_known
from accelcal.methods.triad.model import TriadCalibration
from accelcal.methods.triad.unestimated import with_type_b
from accelcal.rigs.triad import simulate, six_positions
from helpers.cli import refused, run_cli
from helpers.records import make_record

G = 9.80665
INFO = LabInfo(("SN-7",), "op", "2026-01-02T03:04:05+00:00")


@pytest.fixture(scope="module")
def bounded():
    """A six-position triad of pendulous axes, reduced bare and with the default priors."""
    truth = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
    data = simulate(truth, six_positions(), rate=20.0, dwell=1.0, motion=0.5, still=1.0,
                    noise_sd=1e-3, seed=4, gravity=G, axis_models="default")
    means, counts = data.interval_means()

    def again(m):
        return calibrate_known(m, data.up, G, input_unit=data.input_unit, counts=counts)

    bare = again(means)
    return bare, with_type_b(bare, means, again, gravity=G, up=data.up, labels=data.labels)


def test_record_keeps_the_type_b_the_reduction_added(bounded):
    bare, red = bounded
    (rec,) = red.to_records(INFO)
    assert set(rec.type_b) == set(rec.names)
    added = np.diag(red.sensors[0].covariance) - np.diag(bare.sensors[0].covariance)
    np.testing.assert_allclose(rec.type_b_std**2, added, rtol=1e-9)
    np.testing.assert_allclose(rec.type_a_std, bare.sensors[0].std, rtol=1e-6)
    assert rec.type_b["b_x"] > 0.1 * rec.std[0]  # K2, Koo, Kpp look like a bias
    (plain,) = bare.to_records(INFO)
    assert plain.type_b == {}
    assert "type_b" not in plain.to_json()


def test_type_b_survives_json_and_the_store(bounded, tmp_path):
    from accelcal.store import Store

    (rec,) = bounded[1].to_records(INFO)
    doc = json.loads(rec.to_json())
    assert [c["type_b"] for c in doc["coefficients"]] == [rec.type_b[n] for n in rec.names]
    assert CalibrationRecord.from_json(rec.to_json()).type_b == rec.type_b
    with Store(tmp_path / "s.sqlite") as store:
        got = store.record(store.add(rec))
    assert got.type_b == rec.type_b


def test_a_record_without_type_b_reads_as_before():
    rec = make_record()
    doc = json.loads(rec.to_json())
    assert all("type_b" not in c for c in doc["coefficients"])
    back = CalibrationRecord.from_json(json.dumps(doc))
    assert back.type_b == {}
    assert np.isnan(back.type_b_std).all()
    np.testing.assert_array_equal(back.type_a_std, back.std)


@pytest.mark.parametrize(("value", "words"), [
    ("a lot", "type_b must be a finite number"),
    (-1e-7, "finite number >= 0"),
    (1.0, "exceeds its standard uncertainty"),
])
def test_a_bad_type_b_is_refused(value, words):
    doc = json.loads(make_record().to_json())
    doc["coefficients"][0]["type_b"] = value
    with pytest.raises(AccelcalError, match=words):
        CalibrationRecord.from_json(json.dumps(doc), source="cal.json")


def test_type_b_of_a_row_the_record_lacks_is_refused():
    import dataclasses

    with pytest.raises(AccelcalError, match="not a coefficient"):
        dataclasses.replace(make_record(), type_b={"K_X": 1e-7})


def test_report_shows_the_type_b_column_only_where_a_record_has_one(bounded):
    from accelcal.report import Section, render_report

    bare, red = bounded
    (rec,) = red.to_records(INFO)
    html = render_report([Section("triad", record=rec)], title="t")
    assert "of which Type B" in html
    assert "Type A part" in html
    assert f"{rec.type_b['b_x']:.2g}".split("e")[0] in html
    (plain,) = bare.to_records(INFO)
    html = render_report([Section("triad", record=plain)], title="t")
    assert "of which Type B" not in html


def test_records_show_prints_type_a_and_type_b(bounded, tmp_path, capsys):
    (rec,) = bounded[1].to_records(INFO)
    path = tmp_path / "cal.json"
    rec.save(path)
    db = tmp_path / "s.sqlite"
    code, out, _ = run_cli(["records", "add", path, "--db", db], capsys)
    assert code == 0
    for args in (["records", "show", path, "--format", "json"],
                 ["records", "show", "1", "--db", db, "--format", "json"]):
        code, out, _ = run_cli(args, capsys)
        assert code == 0
        rows = json.loads(out)
        assert [r["coefficient"] for r in rows] == list(rec.names)
        for r in rows:
            assert r["type_b"] == rec.type_b[r["coefficient"]]
            assert r["type_a"] ** 2 + r["type_b"] ** 2 == pytest.approx(r["std"] ** 2,
                                                                        rel=1e-12)
    code, out, _ = run_cli(["records", "show", path], capsys)
    assert code == 0
    assert "type_b" in out
    assert "SN-7" in out
    refused(["records", "show", "7", "--db", db], capsys, "no record with id 7")
    refused(["records", "show", "9" * 30, "--db", db], capsys, "no record with id")
    refused(["records", "show", tmp_path / "none.json"], capsys, "not found")
