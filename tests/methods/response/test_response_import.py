"""``accelcal import --kind response``: two-channel recordings made into a response record.

A simulated stepped-sine campaign (five steps at 1 kHz, 1 s each) is written
as a lab would record it: one DAQ CSV per step, and one long TDMS file with
a drive channel; both are imported (frequencies detected, steps detected),
reduced, and compared with the reduction of the simulated record. Then the
bad input of a comparison: clipping, too few periods, a frequency not in
the data, a low coherence (flagged, the rest goes on), a reference that does
not cover the steps.
"""

import json

import numpy as np
import pytest

from accelcal.io.formats.response import read
from accelcal.methods.response.stepped import reduce_stepped
from accelcal.rigs.shaker_response import ResponseRig, default_reference
from helpers.cli import refused, run_cli
from helpers.daq_files import RATE, write_hdf5, write_mat5, write_tdms

FREQS = (10.0, 20.0, 40.0, 80.0, 160.0)


def campaign(noise=0.0):
    """Five 1-s steps at the DAQ helpers' rate: one simulated record per step."""
    return [ResponseRig(frequencies=(f,), periods=int(f), sample_rate=RATE,
                        noise=noise).simulate(seed=k) for k, f in enumerate(FREQS)]


def write_csv(path, ref, dut):
    with open(path, "w") as fh:
        fh.write("t,ref,dut\n")
        np.savetxt(fh, np.c_[np.arange(ref.size) / RATE, ref, dut], delimiter=",",
                   fmt="%.17g")


def reference_csv(path, table):
    rows = list(zip(*table.values(), strict=True))
    path.write_text(",".join(table) + "\n" + "\n".join(",".join(map(repr, r)) for r in rows)
                    + "\n")
    return path


def values(path_or_records):
    red = reduce_stepped(read(path_or_records) if not isinstance(path_or_records, list)
                         else path_or_records)
    return red.observations["frequency_hz"], red.sensors[0].values


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """The campaign as DAQ CSVs (one per step) and one TDMS file, and its own reduction."""
    tmp = tmp_path_factory.mktemp("campaign")
    recs = campaign()
    steps = []
    for k, rec in enumerate(recs):
        write_csv(tmp / f"step{k}.csv", rec.ref, rec.dut)
        steps.append(tmp / f"step{k}.csv")
    drive = np.concatenate([np.sin(2 * np.pi * r.frequency * r.t) for r in recs])
    data = np.c_[np.concatenate([r.ref for r in recs]), np.concatenate([r.dut for r in recs]),
                 drive]
    write_tdms(tmp / "long.tdms", data, np.full(drive.size, 23.0), unit="V")
    ref = reference_csv(tmp / "ref.csv", recs[0].metadata["reference"])
    return tmp, steps, ref, values(recs)


def test_csv_per_step_and_tdms_detected_reduce_to_the_simulated_record(recorded, capsys):
    tmp, steps, ref, (f0, s0) = recorded
    code, out, err = run_cli(["import", *steps, "--kind", "response", "--channels",
                              "ref=ref,dut=dut", "--time", "t", "--unit", "V", "--reference",
                              ref, "--out", tmp / "csv.csv", "--format", "json"], capsys)
    assert code == 0, err
    assert [r["frequency_hz"] for r in json.loads(out)] == list(FREQS)  # detected, nominal
    code, out, err = run_cli(["import", tmp / "long.tdms", "--kind", "response", "--channels",
                              "ref=Accel/X,dut=Accel/Y,drive=Accel/Z", "--steps", "detect",
                              "--step-window", "0.2", "--reference", ref,
                              "--out", tmp / "tdms.parquet", "--format", "json"], capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert [r["frequency_hz"] for r in rows] == list(FREQS)
    # each step starts one window (0.2 s) after its change of frequency
    np.testing.assert_allclose([r["start_s"] for r in rows], np.arange(5) + 0.2, atol=0.11)
    for name in ("csv.csv", "tdms.parquet"):
        f, s = values(tmp / name)
        np.testing.assert_array_equal(f, f0)
        # an exact record: the same magnitudes (1e-6 relative) and phases (1e-4 deg)
        np.testing.assert_allclose(np.abs(s), np.abs(s0), rtol=1e-6)
        np.testing.assert_allclose(np.angle(s / s0, deg=True), 0.0, atol=1e-4)


@pytest.mark.parametrize("form", ["hdf5", "mat", "parquet"])
def test_other_formats_one_file_per_step_with_given_frequencies(form, tmp_path, capsys):
    import pyarrow as pa
    import pyarrow.parquet as pq

    recs = campaign()[1:3]
    files = []
    for k, rec in enumerate(recs):
        data = np.c_[rec.ref, rec.dut, rec.ref]
        path = tmp_path / f"s{k}.{ {'hdf5': 'h5', 'mat': 'mat', 'parquet': 'parquet'}[form]}"
        if form == "hdf5":
            write_hdf5(path, data, np.full(rec.ref.size, 23.0), unit="V")
        elif form == "mat":
            write_mat5(path, data, np.full(rec.ref.size, 23.0))
        else:
            pq.write_table(pa.table({"t": rec.t, "ref": rec.ref, "dut": rec.dut}), path)
        files.append(path)
    mapping = {"hdf5": ["--channels", "ref=daq/acc[0],dut=daq/acc[1]", "--time", "daq/t"],
               "mat": ["--channels", "ref=data[0],dut=data[1]", "--rate", str(RATE),
                       "--unit", "V"],
               "parquet": ["--channels", "ref=ref,dut=dut", "--time", "t", "--unit", "V"]}[form]
    out = tmp_path / "r.csv"
    ref = reference_csv(tmp_path / "ref.csv", recs[0].metadata["reference"])
    code, _, err = run_cli(["import", *files, "--kind", "response", *mapping, "--frequencies",
                            "20,40", "--reference", ref, "--out", out], capsys)
    assert code == 0, err
    f, s = values(out)
    f0, s0 = values(recs)
    np.testing.assert_array_equal(f, f0)
    np.testing.assert_allclose(s, s0, rtol=1e-9)


@pytest.fixture
def steps(tmp_path):
    recs = campaign(noise=1e-4)[1:3]
    return tmp_path, recs


def _import(tmp_path, recs, extra=(), name="r.csv"):
    files = []
    for k, rec in enumerate(recs):
        write_csv(tmp_path / f"s{k}.csv", *rec)
        files.append(tmp_path / f"s{k}.csv")
    return ["import", *files, "--kind", "response", "--channels", "ref=ref,dut=dut", "--time",
            "t", "--unit", "V", "--out", tmp_path / name, *extra]


def test_bad_steps_refused_in_one_line(steps, capsys):
    tmp, (a, b) = steps
    peak = np.abs(b.dut).max()
    clipped = (a.ref, a.dut), (b.ref, np.clip(b.dut, -0.95 * peak, 0.95 * peak))
    refused(_import(tmp, clipped), capsys, "s1.csv, step at 0 s (40 Hz): the dut channel is "
            "clipped")
    short = (a.ref[:100], a.dut[:100]), (b.ref, b.dut)  # 2 periods of 20 Hz
    refused(_import(tmp, short, ["--frequencies", "20,40"]), capsys,
            "2 whole periods, fewer than 3")
    whole = (a.ref, a.dut), (b.ref, b.dut)
    refused(_import(tmp, whole, ["--frequencies", "20,55"]), capsys, "55 Hz is not in the data")
    silent = (np.zeros(1000), a.dut), (b.ref, b.dut)
    refused(_import(tmp, silent), capsys, "no frequency found in the data")
    table = default_reference().to_dict()
    cut = {k: v[:3] for k, v in table.items()}
    assert cut["frequency_hz"][-1] < 40
    reference_csv(tmp / "cut.csv", cut)
    refused(_import(tmp, whole, ["--reference", tmp / "cut.csv"]), capsys,
            "covers 1-10 Hz, not the step at 20 Hz")
    refused(_import(tmp, whole, ["--steps", "detect", "--frequencies", "20,40"]), capsys,
            "detected steps take their frequencies from the data")
    refused(_import(tmp, whole[:1], ["--kind", "noise", "--min-periods", "3"]), capsys,
            "--min-periods applies to --kind response only")
    refused(_import(tmp, whole, ["--kind", "noise"]), capsys, "--kind noise imports one "
            "recording, not 2")
    assert not (tmp / "r.csv").exists()


def test_detected_step_shorter_than_the_stated_periods_refused(tmp_path, capsys):
    recs = campaign()
    parts = [(recs[3].ref, recs[3].dut), (recs[4].ref[:300], recs[4].dut[:300])]
    write_csv(tmp_path / "long.csv", *(np.concatenate(c) for c in zip(*parts, strict=True)))
    args = ["import", tmp_path / "long.csv", "--kind", "response", "--channels",
            "ref=ref,dut=dut", "--time", "t", "--unit", "V", "--steps", "detect",
            "--step-window", "0.05", "--format", "json", "--out", tmp_path / "r.csv"]
    # 80 Hz for 1 s (72 periods once trimmed), 160 Hz for 0.3 s (32 periods)
    refused([*args, "--min-periods", "40"], capsys, "the step at 160 Hz from 1 s holds 32",
            "fewer than 40")
    code, out, err = run_cli([*args, "--min-periods", "20"], capsys)
    assert code == 0, err
    assert [(r["frequency_hz"], r["periods"]) for r in json.loads(out)] == [(80, 72),
                                                                            (160, 32)]


def test_low_coherence_flags_the_step_and_the_rest_goes_on(steps, capsys):
    tmp, (a, b) = steps
    rng = np.random.default_rng(3)
    noisy = (a.ref, a.dut), (b.ref, b.dut + rng.normal(0, np.abs(b.dut).max(), b.dut.size))
    ref = reference_csv(tmp / "ref.csv", a.metadata["reference"])
    code, out, err = run_cli(_import(tmp, noisy, ["--format", "json", "--reference", ref]),
                             capsys)
    assert code == 0, err
    rows = json.loads(out)
    assert [r["flagged"] for r in rows] == ["", "yes"]
    assert rows[1]["coherence"] < 0.9 < rows[0]["coherence"]
    assert "1 step(s) flagged" in err
    rec = read(tmp / "r.csv")
    assert [f["step"] for f in rec.metadata["flagged"]] == [1]
    assert rec.metadata["flagged"][0]["reason"].startswith("coherence")
    code, out, err = run_cli(["response", "reduce", tmp / "r.csv",
                              "--reference-frequency", "20"], capsys)
    assert code == 0, err
    assert "1 step(s) flagged at import, coherence below the limit: 40 Hz" in out
