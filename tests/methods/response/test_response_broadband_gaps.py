"""A gap in a broadband record's time column: refused by default with the hint, never
filled (interpolated random excitation biases H1), and with --gaps split the Welch averages
taken over the pieces between gaps and pooled, within the stated uncertainty of the gap-free
record's H1; a piece shorter than one Welch segment is left out and counted."""

import csv
import dataclasses
import io

import numpy as np
import pytest

from accelcal.io.formats import response as response_format
from helpers.cli import refused, run_cli

_COLUMNS = ("step", "frequency", "t", "ref", "dut")


def _without(rec, lost: slice):
    keep = np.ones(rec.t.size, dtype=bool)
    keep[lost] = False
    return dataclasses.replace(rec, **{c: getattr(rec, c)[keep] for c in _COLUMNS},
                               quadrature=None)


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    from accelcal.cli import main

    folder = tmp_path_factory.mktemp("broadband_gap")
    path = folder / "random.csv"
    with pytest.raises(SystemExit) as exc:
        main(["response", "simulate", "--excitation", "random", "--duration", "2", "--band",
              "20,2000", "--noise", "1e-3", "--out", str(path)])
    assert exc.value.code == 0
    rec = response_format.read(path)
    gapped, early = folder / "gapped.csv", folder / "early.csv"
    response_format.write(gapped, _without(rec, slice(10000, 10050)))  # 50 samples lost
    response_format.write(early, _without(rec, slice(200, 230)))  # before one segment (512)
    return path, gapped, early


def _rows(out):
    return {float(r["frequency_hz"]): r for r in csv.DictReader(io.StringIO(out))}


def test_a_gap_is_refused_and_never_filled(records, capsys):
    _, gapped, _ = records
    refused(["response", "reduce", gapped], capsys, "data row 10001",
            "about 50 samples missing", "--gaps split", "bias H1")
    refused(["response", "reduce", gapped, "--gaps", "fill"], capsys, "bias H1")


def test_split_pools_the_pieces_within_the_stated_uncertainty(records, capsys):
    path, gapped, _ = records
    code, whole, _ = run_cli(["response", "reduce", path, "--format", "csv"], capsys)
    assert code == 0
    code, out, err = run_cli(["response", "reduce", gapped, "--gaps", "split", "--format",
                              "csv"], capsys)
    assert code == 0, err
    assert "note: 1 gaps in the time column (data rows 10001): split" in err
    assert "note: 2 segments (samples 0-10000, 10000-19950)" in err
    a, b = _rows(whole), _rows(out)
    common = sorted(set(a) & set(b))
    assert len(common) > 0.9 * len(a)
    dm = np.array([abs(float(b[f]["magnitude"]) - float(a[f]["magnitude"])) for f in common])
    um = np.array([float(b[f]["magnitude_u"]) for f in common])
    dp = np.array([abs(float(b[f]["phase_deg"]) - float(a[f]["phase_deg"])) for f in common])
    up = np.array([float(b[f]["phase_u"]) for f in common])
    assert (dm < 2 * um).all()
    assert np.median(dm / um) < 1.0
    assert (dp < 2 * up).all()
    assert np.median(dp / up) < 1.0
    assert (dm > 0).any()  # the segments did move: a different estimate, not the same one


def test_a_piece_shorter_than_a_segment_is_left_out_and_counted(records):
    from accelcal.methods.response import reduce

    path, _, early = records
    whole = reduce(path)
    red = reduce(early, gaps="split")
    found = {f["found"]: f for f in red.provenance["repairs"]["found"]}
    short = found["pieces shorter than one Welch segment"]
    assert short["count"] == 1
    assert short["first_rows"] == [1]
    assert short["action"] == "left out (200 samples)"
    assert found["gaps in the time column"]["first_rows"] == [201]
    assert red.provenance["samples"] == whole.provenance["samples"] - 30
    # the 200 samples before the gap hold no segment: the pooled averages are the later
    # piece's alone, fewer than the gap-free record's
    assert red.provenance["segments"] < whole.provenance["segments"]
