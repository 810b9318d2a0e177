"""Degrees of freedom, Student-t expanded uncertainty and simulated provenance in records."""

import dataclasses
import json

import numpy as np
import pytest
import sqlalchemy as sa

from accelcal.calibration import coverage_factor
from accelcal.cli import main
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.lab_metadata import LabInfo
from accelcal.report import render_report
from accelcal.report.sections import reduction_sections
from accelcal.results import Estimate, Reduction
from accelcal.store import SCHEMA_VERSION, Store
from helpers.records import make_record


@pytest.mark.parametrize(("dof", "k"), [(1, 13.97), (2, 4.53), (5, 2.65), (10, 2.28),
                                        (20, 2.13), (50, 2.05)])
def test_coverage_factor_is_gums_table_g2(dof, k):
    # JCGM 100:2008 Table G.2, column p = 95.45 %, to the printed two decimals
    assert coverage_factor(dof) == pytest.approx(k, abs=0.005)


def test_known_noise_keeps_k_2():
    assert coverage_factor(0) == 2.0


def _reduction(dof):
    names = ("K0", "K1")
    est = Estimate(names, [1e-4, 1.3], np.diag([1e-12, 1e-12]), {"K0": "g", "K1": "V/g"}, "x",
                   residuals=np.zeros(dof + 2), dof=dof)
    return Reduction("tumble", "tumble/lsq", (est,), dof=dof)


def test_records_carry_dof_and_t_factor_and_warn_below_ten():
    info = LabInfo(("SN",), "", "2026-01-01T00:00:00+00:00")
    (few,) = _reduction(1).to_records(info)
    assert few.dof == 1
    assert few.coverage_factor == pytest.approx(13.97, abs=0.005)
    np.testing.assert_allclose(few.expanded, few.coverage_factor * few.std)
    assert any(n.startswith("only 1 degrees of freedom") for n in few.notes)
    (many,) = _reduction(50).to_records(info)
    assert not any(n.startswith("only") for n in many.notes)
    (known,) = _reduction(0).to_records(info)
    assert known.dof is None
    assert known.coverage_factor == 2.0
    back = CalibrationRecord.from_json(few.to_json())
    assert back.dof == 1
    assert back.coverage_factor == few.coverage_factor


def test_simulated_inputs_are_marked_in_records_store_and_report(tmp_path, capsys):
    from accelcal import default_model
    from accelcal.methods.tumble import reduce_tumble
    from accelcal.rigs.tumble import simulate, uniform_positions

    sim = simulate(uniform_positions(24), default_model(), noise=1e-6, seed=2)
    red = reduce_tumble(sim.angles_rad, sim.outputs[:, 0], rotation_axis=sim.rotation_axis)
    (rec,) = red.to_records(LabInfo(("SN-S",), "", "2026-01-01T00:00:00+00:00",
                                    simulated=True))
    assert rec.simulated
    assert "simulated data: the inputs were written by a simulator, not measured" in rec.notes
    assert json.loads(rec.to_json())["simulated"] is True
    html = render_report(reduction_sections(red, [rec]), title="t")
    assert "<strong>simulated</strong> (not a measurement)" in html
    store = tmp_path / "s.sqlite"
    path = tmp_path / "r.json"
    rec.save(path)
    assert main_exit(["records", "add", str(path), "--db", str(store)]) == 0
    capsys.readouterr()
    assert main_exit(["records", "list", "--db", str(store), "--format", "json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["simulated"] is True


def main_exit(argv) -> int:
    with pytest.raises(SystemExit) as info:
        main(argv)
    return info.value.code


def test_records_written_before_dof_and_simulated_still_load():
    data = json.loads(make_record().to_json())
    del data["dof"], data["simulated"]
    rec = CalibrationRecord.from_json(json.dumps(data))
    assert rec.dof is None
    assert rec.simulated is False
    for bad in ({"dof": 0}, {"dof": True}, {"simulated": 1}):
        with pytest.raises(ValueError, match=r"dof|simulated"):
            CalibrationRecord.from_json(json.dumps({**data, **bad}))


def test_schema_1_store_migrates_to_the_simulated_column(db):
    # Build a schema-1 store as an older accelcal left it: no simulated column.
    engine = sa.create_engine(db if "://" in db else f"sqlite:///{db}")
    meta = sa.MetaData()
    sa.Table("schema_info", meta, sa.Column("version", sa.Integer, nullable=False))
    sa.Table("calibrations", meta,
             sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
             sa.Column("uid", sa.String(64), nullable=False, unique=True),
             sa.Column("serial", sa.String(200), nullable=False),
             sa.Column("method", sa.String(200), nullable=False),
             sa.Column("date", sa.String(40), nullable=False),
             sa.Column("software", sa.String(100), nullable=False),
             sa.Column("record_json", sa.Text, nullable=False))
    sa.Table("coefficients", meta,
             sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
             sa.Column("calibration_id", sa.Integer, sa.ForeignKey("calibrations.id"),
                       nullable=False),
             sa.Column("name", sa.String(100), nullable=False),
             sa.Column("unit", sa.String(40), nullable=False),
             sa.Column("estimate", sa.Float, nullable=False),
             sa.Column("std", sa.Float, nullable=True))
    old = make_record(serial="OLD")
    with engine.begin() as conn:
        meta.create_all(conn)
        conn.execute(sa.insert(meta.tables["schema_info"]).values(version=1))
        conn.execute(sa.insert(meta.tables["calibrations"]).values(
            uid="u1", serial="OLD", method=old.method, date=old.date, software=old.software,
            record_json=old.to_json()))
    engine.dispose()
    with Store(db, readonly=True) as store:  # read as it is, without migrating
        assert [r["simulated"] for r in store.calibrations()] == [False]
        assert store.schema_version == 1
    with Store(db) as store:
        assert store.schema_version == SCHEMA_VERSION == 5
        store.add(dataclasses.replace(make_record(serial="NEW"), simulated=True))
        rows = {r["serial"]: r["simulated"] for r in store.calibrations()}
    assert rows == {"OLD": False, "NEW": True}


def test_dividing_head_simulate_marks_its_file_and_the_records_as_simulated(tmp_path):
    data, rec = tmp_path / "h.csv", tmp_path / "cal.json"
    assert main_exit(["dividing-head", "simulate", "--seed", "1", "--out", str(data)]) == 0
    assert main_exit(["dividing-head", "reduce", str(data), "--record", str(rec),
                      "--serial", "A,B,C,D"]) == 0
    for k in range(1, 5):
        assert CalibrationRecord.load(tmp_path / f"cal-{k}.json").simulated
