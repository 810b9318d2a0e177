"""Calibration records from every reduction; file round trips; fuzzed readers; --record."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from accelcal import AccelcalError
from accelcal.calibration import lab_info, record_paths, save_records
from accelcal.cli import main
from accelcal.defaults import default_model
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.io.formats.dividing_head import read_head_record, write_head_record
from accelcal.io.formats.shaker import read_records, write_records
from accelcal.io.formats.vibrafuge import read_vibrafuge, write_vibrafuge
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata, read_lab_metadata
from accelcal.methods import transverse, vre
from accelcal.methods.dividing_head import HeadData, options_from_record, reduce
from accelcal.methods.vre import reduce_run
from accelcal.model import ErrorModel
from accelcal.rigs import vibrafuge
from accelcal.rigs.dividing_head import (
    DONG2014_FIRST_HARMONIC,
    AngleErrorProfile,
    DividingHeadRig,
    dong2014_models,
    simulate,
)
from accelcal.rigs.shaker import ShakerRig
from accelcal.units import ARCSEC
from helpers.paths import EXAMPLES

LAB = {"operator": "J. Smith", "date": "2026-11-20T09:30:00+00:00", "local_gravity": 9.80122}
SERIALS = ["SN-1", "SN-2", "SN-3", "SN-4"]
# Files store angles in degrees: the rad -> deg -> rad trip changes an angle by
# at most an ulp (2e-16 relative); the reductions' designs are conditioned well
# enough (cond < 1e3) that estimates agree to 1e-12 relative. Outputs are
# written with 17 significant digits, so they round-trip exactly. Absolute
# floors: 1e-15 of the output unit (1e-9 of the smallest SD in these tests).
RTOL, ATOL = 1e-12, 1e-15


def _head_run(seed=0):
    rig = DividingHeadRig.uniform(24, dong2014_models(4),
                                  angle_error=AngleErrorProfile.uniform(2 * ARCSEC),
                                  first_harmonic=DONG2014_FIRST_HARMONIC, noise=2.8e-6)
    return rig, simulate(rig, np.random.default_rng(seed))


def _info(serials=SERIALS):
    return LabInfo(tuple(serials), LAB["operator"], LAB["date"], LAB["local_gravity"])


# ----------------------------------------------------------------- round trips
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_head_round_trip_file_equals_memory(tmp_path, suffix):
    rig, run = _head_run()
    path = tmp_path / f"head{suffix}"
    write_head_record(path, rig.positions, run.outputs, rig.mounts,
                      first_harmonic=DONG2014_FIRST_HARMONIC, first_harmonic_sd=5e-7,
                      lab={"serial": SERIALS, **LAB})
    memory = reduce(HeadData.build(rig.positions, run.outputs, rig.mounts), "joint",
                    first_harmonic=DONG2014_FIRST_HARMONIC, first_harmonic_sd=5e-7)
    rec = read_head_record(path)
    from_file = reduce(HeadData.from_record(rec), "joint", **options_from_record(rec, "joint"))
    for a, b in zip(memory.sensors, from_file.sensors, strict=True):
        np.testing.assert_allclose(b.values, a.values, rtol=RTOL, atol=ATOL)
        # Variances are ~1e-12 V^2; structurally zero covariances are rounding
        # noise (~1e-28), so the floor is 1e-9 of the variances.
        np.testing.assert_allclose(b.covariance, a.covariance, rtol=1e-9, atol=1e-21)
    info = lab_info([path], sensors=4)
    assert info == _info()
    recs = from_file.to_records(info, input_files=[path])
    assert [r.serial for r in recs] == SERIALS
    assert all(r.date == LAB["date"] and r.operator == "J. Smith" for r in recs)
    assert all(r.method == "dividing-head/joint" for r in recs)
    assert any("local gravity 9.80122" in n for n in recs[0].notes)
    # The record's model is Dong2014 eq. (5) of the estimates.
    v = {recs[2].plain.get(n, n): e for n, e in zip(recs[2].names, recs[2].estimates,
                                                     strict=True)}  # K_F+K_OO -> K_F
    expected = ErrorModel.from_dong2014(v["K_F"], v["K_I"], v["K_O"], v["K_IO"], v["K_II"])
    for term in ("K0", "K1", "Ko", "Kio", "K2"):
        assert getattr(recs[2].model, term) == pytest.approx(getattr(expected, term), rel=1e-15)
    # sigma of the model: the pooled residual SD in g; the simulated noise is
    # 2.8e-6 V. With 55 degrees of freedom the SD estimate has a relative
    # standard error of 1/sqrt(110) = 10 %: allow 30 %.
    assert recs[2].model.sigma == pytest.approx(2.8e-6 / v["K_I"], rel=0.3)
    # Truth within 5 standard uncertainties (noise and the random head error).
    truth = dong2014_models(4)[0].to_dong2014()
    for name, value, std in zip(recs[0].names, recs[0].estimates, recs[0].std, strict=True):
        assert abs(value - truth[recs[0].plain.get(name, name)]) < 5 * std + 1e-12, name
    # JSON round trip of the record.
    save_records(recs, tmp_path / "cal.json")
    loaded = CalibrationRecord.load(tmp_path / "cal-3.json")
    assert loaded.to_json() == recs[2].to_json()
    assert loaded.inputs == {path.name: recs[2].inputs[path.name]}


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_shaker_round_trip_file_equals_memory(tmp_path, suffix):
    model = default_model()
    records = ShakerRig(amplitude=5.0, sample_rate=2560.0, periods=8.0).simulate(
        model, np.deg2rad(np.arange(0.0, 360.0, 30.0)), rng=np.random.default_rng(4))
    paths = write_records(records, tmp_path / "sweep", suffix=suffix,
                          extra={"serial": "SN-9", **LAB})
    assert all(p.suffix == suffix for p in paths)
    assert len(paths) == 12
    memory = transverse.identify(records)
    (back,) = read_records(tmp_path / "sweep")
    from_file = transverse.identify(back)
    np.testing.assert_allclose(from_file.estimate.values, memory.estimate.values, rtol=RTOL,
                               atol=1e-20)
    np.testing.assert_allclose(from_file.estimate.covariance, memory.estimate.covariance,
                               rtol=1e-9)
    info = lab_info(paths)
    (rec,) = from_file.to_records(info, input_files=paths)
    assert rec.notes[0] == f"shaker vibration amplitude {back.amplitude:g} g"
    assert rec.serial == "SN-9"
    assert rec.names == ("Ko", "Kp", "Koo", "Kpp", "Kop")
    assert rec.units["Koo"] == "g/g^2"
    assert len(rec.inputs) == 12
    # The identified terms are the model's within 5 SD (noise only).
    for name, value, std in zip(rec.names, rec.estimates, rec.std, strict=True):
        assert abs(value - getattr(model, name)) < 5 * std, name


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_vibrafuge_round_trip_file_equals_memory(tmp_path, suffix):
    model = default_model()
    b, a = (x.ravel() for x in np.meshgrid([1.0, 2.0, 4.0], [5.0, 7.0, 9.0], indexing="ij"))
    run = vibrafuge.simulate(model, b, a, frequency=50.0, sample_rate=2000.0, duration=0.2,
                             rng=np.random.default_rng(5))
    path = tmp_path / f"vib{suffix}"
    write_vibrafuge(path, run, provenance={"serial": "SN-7", **LAB})
    mem = reduce_run(run)
    got = reduce_run(read_vibrafuge(path))
    np.testing.assert_array_equal(got.vre, mem.vre)  # samples round-trip exactly
    np.testing.assert_array_equal(got.uncertainty, mem.uncertainty)
    fit = vre.identify(got.overload, got.amplitude, got.vre, got.uncertainty,
                       direction=got.direction)
    (rec,) = fit.to_records(lab_info([path]), input_files=[path])
    assert rec.serial == "SN-7"
    assert rec.names == ("K2", "K3", "K0_asym", "K1_asym")
    np.testing.assert_array_equal(rec.estimates, fit.estimate.values)


def test_vre_record_leaves_out_unidentifiable_terms_and_notes_combinations():
    # One overload only: K2 and K3 enter as K2 + 3 b K3 (Guan2021 eq. (9)),
    # so they cannot be separated; the record keeps only what is identified.
    amp = np.array([5.0, 6.0, 7.0, 8.0, 9.0])
    b = np.full(5, 2.0)
    truth = default_model()
    pred, _ = vre.vector_vre(truth, vre.along_ia(b), amp)
    fit = vre.identify(b, amp, pred, np.full(5, 1e-8), terms=("K2", "K3", "K1_asym"))
    assert set(fit.unidentified()) == {"K2", "K3"}
    (rec,) = fit.to_records(_info(["SN-1"]))
    assert rec.names == ("K1_asym",)
    assert any(n.startswith("not identifiable from this design: K2") for n in rec.notes)
    assert any("determined combination" in n and "K3" in n for n in rec.notes)


def test_lab_info_merges_files_and_overrides(tmp_path):
    rig, run = _head_run()
    for name, op in (("a.csv", "A"), ("b.csv", "B")):
        write_head_record(tmp_path / name, rig.positions, run.outputs, rig.mounts,
                          lab={"serial": SERIALS, "operator": op})
    with pytest.raises(AccelcalError, match="disagree on their operator"):
        lab_info([tmp_path / "a.csv", tmp_path / "b.csv"], sensors=4)
    info = lab_info([tmp_path / "a.csv", tmp_path / "b.csv"], sensors=4, operator="C")
    assert info.operator == "C"
    assert info.serials == tuple(SERIALS)
    assert lab_info([tmp_path / "a.csv"], sensors=4, serial="w,x,y,z").serials == (
        "w", "x", "y", "z")
    with pytest.raises(AccelcalError, match="give 4 non-empty serial"):
        lab_info([tmp_path / "a.csv"], sensors=4, serial="w,x")
    write_head_record(tmp_path / "c.csv", rig.positions, run.outputs, rig.mounts)
    with pytest.raises(AccelcalError, match="no serial number") as info:
        lab_info([tmp_path / "c.csv"], sensors=4)
    assert info.value.parameter == "serial"


@pytest.mark.parametrize(("meta", "match"), [
    ({"serial": ""}, "non-empty string"),
    ({"serial": ["a", "b"]}, "2 serial number"),
    ({"serial": 12}, "non-empty string"),
    ({"operator": 3}, "operator"),
    ({"date": "yesterday"}, "ISO 8601"),
    ({"local_gravity": 1.0}, "m/s\\^2"),
    ({"local_gravity": True}, "m/s\\^2"),
    ({"local_gravity": float("nan")}, "m/s\\^2"),
])
def test_lab_metadata_errors_name_the_field(meta, match):
    with pytest.raises(AccelcalError, match=match):
        check_lab_metadata(meta, "f.csv")


def test_record_paths_insert_the_index():
    assert record_paths("out/cal.json", 1) == [Path("out/cal.json")]
    assert record_paths("out/cal.json", 3)[2] == Path("out/cal-3.json")


# ------------------------------------------------------------------- the CLI
def _run(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    return exc.value.code, capsys.readouterr()


def test_cli_record_options_write_one_record_per_sensor_and_method(tmp_path, capsys):
    head = tmp_path / "head.parquet"
    shutil.copy(EXAMPLES / "indexing_head.parquet", head)
    code, out = _run(["dividing-head", "reduce", str(head), "--record",
                      str(tmp_path / "h.json"), "--operator", "K. Lee"], capsys)
    assert code == 0, out.err
    recs = [CalibrationRecord.load(tmp_path / f"h-{k}.json") for k in range(1, 5)]
    assert [r.serial for r in recs] == ["ACC-0001", "ACC-0002", "ACC-0003", "ACC-0004"]
    assert recs[0].operator == "K. Lee"
    assert recs[0].date == "2026-11-20T09:30:00+00:00"
    code, out = _run(["vre", "fit", str(EXAMPLES / "vibrafuge.csv"), "--record",
                      str(tmp_path / "v.json"), "--serial", "OTHER"], capsys)
    assert code == 0, out.err
    assert CalibrationRecord.load(tmp_path / "v.json").serial == "OTHER"
    code, out = _run(["transverse", "fit", str(EXAMPLES / "shaker"), "--record",
                      str(tmp_path / "t.json")], capsys)
    assert code == 0, out.err
    rec = CalibrationRecord.load(tmp_path / "t.json")
    assert rec.serial == "ACC-0001"
    assert len(rec.inputs) == 12


@pytest.mark.parametrize("argv", [
    ["dividing-head", "reduce", "{head}", "--record", "{out}", "--serial", "a,b"],
    ["dividing-head", "reduce", "{head}", "--serial", "a,b,c,d"],
    ["vre", "fit", "{vib}", "--operator", "x"],
    ["transverse", "fit", "{shaker}", "--serial", "x"],
    ["dividing-head", "reduce", "{head}", "--record", "{tmp}/missing/dir/c.json"],
])
def test_cli_record_errors_exit_2_and_write_nothing(tmp_path, capsys, argv):
    argv = [a.format(head=EXAMPLES / "indexing_head.csv", vib=EXAMPLES / "vibrafuge.csv",
                     shaker=EXAMPLES / "shaker", out=tmp_path / "c.json", tmp=tmp_path)
            for a in argv]
    code, out = _run(argv, capsys)
    assert code == 2
    assert out.err.startswith("accelcal: error:")
    assert "Traceback" not in out.err
    assert list(tmp_path.rglob("*.json")) == []


# ---------------------------------------------------------------- fuzzed readers
# Numbers in fuzzed metadata: any sign and zero, NaN and inf, and magnitudes
# 1e-6..1e6 (physically absurd ones such as a 1e-307 V/g scale factor overflow
# the arithmetic of any reduction; readers check types, signs and finiteness).
_NUMBERS = (st.integers(-10**6, 10**6) | st.sampled_from([0.0, -0.0, math.nan, math.inf])
            | st.floats(1e-6, 1e6) | st.floats(-1e6, -1e-6))
_JSON = st.recursive(
    st.none() | st.booleans() | _NUMBERS | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner,
                                                                 max_size=4),
    max_leaves=8,
)
_KINDS = {
    "head": (EXAMPLES / "indexing_head.csv",
             ["dividing-head", "reduce", "{file}", "--record", "{out}"]),
    "vibrafuge": (EXAMPLES / "vibrafuge.csv", ["vre", "fit", "{file}", "--record", "{out}"]),
    "shaker": (EXAMPLES / "shaker" / "shaker_A5g_theta000.00.csv",
               ["transverse", "fit", "{dir}", "--record", "{out}"]),
}


def _mutate_csv(text: str, data) -> str:
    lines = text.split("\n")
    choice = data.draw(st.sampled_from(["meta-field", "meta-drop", "cell", "cut", "header"]))
    meta = json.loads(lines[1][2:])
    if choice == "meta-field":
        key = data.draw(st.sampled_from([*sorted(meta), "serial", "date", "local_gravity"]))
        meta[key] = data.draw(_JSON)
        lines[1] = "# " + json.dumps(meta)
    elif choice == "meta-drop":
        meta.pop(data.draw(st.sampled_from(sorted(meta))))
        lines[1] = "# " + json.dumps(meta)
    elif choice == "cell":
        row = data.draw(st.integers(3, len(lines) - 2))
        cells = lines[row].split(",")
        col = data.draw(st.integers(0, len(cells) - 1))
        cells[col] = data.draw(st.sampled_from(["", "nan", "inf", "x", "1e999", "--1"])
                               | st.text(max_size=5))
        lines[row] = ",".join(cells)
    elif choice == "cut":
        return text[: data.draw(st.integers(0, len(text) - 1))]
    else:
        lines[2] = data.draw(st.text(max_size=20))
    return "\n".join(lines)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(sorted(_KINDS)), data=st.data())
def test_fuzzed_record_files_fail_only_with_the_documented_error(tmp_path_factory, capsys,
                                                                   kind, data):
    source, argv = _KINDS[kind]
    work = tmp_path_factory.mktemp("fuzz")
    target = work / "in" / source.name
    target.parent.mkdir()
    if kind == "shaker":  # a sweep needs several angles: copy them, corrupt one
        for f in source.parent.glob("*.csv"):
            shutil.copy(f, target.parent / f.name)
    target.write_text(_mutate_csv(source.read_text(encoding="utf-8"), data), encoding="utf-8")
    out = work / "rec" / "cal.json"
    out.parent.mkdir()
    try:
        if kind == "head":
            read_head_record(target)
        elif kind == "vibrafuge":
            read_vibrafuge(target)
        else:
            read_records(target.parent)
        read_lab_metadata(target)
    except AccelcalError:
        pass
    code, err = _run([a.format(file=target, dir=target.parent, out=out) for a in argv], capsys)
    if code != 0:
        assert code == 2
        assert "Traceback" not in err.err
        assert list(out.parent.iterdir()) == []


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(["serial", "date", "local_gravity", "operator", "sensors",
                            "mount_phases_deg", "output_unit"]),
       value=_JSON, column=st.sampled_from(["none", "strings", "nulls"]))
def test_fuzzed_parquet_head_files_fail_only_with_the_documented_error(tmp_path_factory, key,
                                                                        value, column):
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(EXAMPLES / "indexing_head.parquet")
    meta = json.loads(table.schema.metadata[b"accelcal"])
    meta[key] = value
    if column == "strings":
        table = table.set_column(1, "U1", pa.array(["x"] * table.num_rows))
    elif column == "nulls":
        table = table.set_column(1, "U1", pa.array([None] * table.num_rows, pa.float64()))
    path = tmp_path_factory.mktemp("pq") / "head.parquet"
    pq.write_table(table.replace_schema_metadata({"accelcal": json.dumps(meta)}), path)
    try:
        rec = read_head_record(path)
        lab_info([path], sensors=len(rec.sensors))
    except AccelcalError:
        return
