"""Clipped samples in a triad recording: found (given rails or automatically), left out of
the static intervals and the fit, counted in the notes and the provenance; refused only
when too few intervals remain, saying how many clipping dropped."""

import json

import numpy as np
import pytest

from accelcal.io.recordings import Recording
from accelcal.io.recordings.read import Block
from accelcal.methods.triad.lab import run
from accelcal.methods.triad.model import TriadCalibration
from accelcal.rigs.triad import simulate
from accelcal.signal.clipping import AUTO_MIN_RUN, ClipFinder
from accelcal.signal.static import detect_static
from accelcal.signal.static_stream import detect_static_stream
from helpers.cli import refused, run_cli

TRUTH = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
RAIL = 9.0  # m/s^2: a range that clips every axis held up (about 9.9 m/s^2)


@pytest.fixture(scope="module")
def triad():
    rec = simulate(TRUTH, 16, seed=4, still=5, dwell=3, motion=1, noise_sd=0.005)
    return rec.acc, rec.t - rec.t[0]


def _recording(values, t):
    return Recording(values, ("x", "y", "z"), "m/s^2", 100.0, t)


def _csv(path, values, t):
    rows = ["t,x,y,z", *(",".join(repr(float(v)) for v in (ti, *row))
                         for ti, row in zip(t, values, strict=True))]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_nothing_is_flagged_on_clean_noise():
    rng = np.random.default_rng(11)
    finder = ClipFinder(3)
    finder(rng.normal(0.0, 1.0, (100_000, 3)))  # not quantised: no value repeats
    assert finder.count == 0
    finder = ClipFinder(3)
    finder(np.round(rng.normal(0.2, 1.0, (100_000, 3))))  # ADC counts, SD one count
    assert finder.count == 0


def test_clipping_is_found_at_the_extreme_or_the_rails(triad):
    acc, _ = triad
    finder = ClipFinder(3)
    finder(acc)
    assert finder.count == 0
    clipped = np.minimum(acc, RAIL)
    auto = ClipFinder(3)
    mask = auto(clipped)
    beyond = (acc > RAIL).any(axis=1)
    # every held position beyond the rail is found; a short excursion in a motion may not be
    assert auto.count == mask.sum() > 0.9 * beyond.sum()
    assert not (mask & ~beyond).any()
    given = ClipFinder(3, (-20.0, RAIL))
    assert (given(clipped) == (beyond & _in_runs(beyond, 3))).all()
    assert "10 or more identical" in auto.rule()
    assert AUTO_MIN_RUN == 10


def _in_runs(flag, n):
    """Samples of ``flag`` in runs of at least ``n``."""
    out = np.zeros_like(flag)
    edges = np.diff(np.r_[0, flag.astype(int), 0])
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        out[a:b] = b - a >= n
    return out


def test_a_run_across_blocks_is_found_whole():
    x = np.r_[np.linspace(0, 1, 50), np.ones(12), np.linspace(1, 0, 50)[1:]]
    values = np.column_stack([x, -x, 0 * x + 0.5 + 1e-3 * np.sin(np.arange(x.size))])
    whole = ClipFinder(3)
    expected = whole(values)
    streamed = ClipFinder(3)
    got = np.concatenate([streamed(values[:55]), streamed(values[55:])])
    assert whole.runs == streamed.runs == 2  # the top of x and the bottom of -x
    assert expected.sum() == 13  # the 12 ones and the ramp's last sample, equal to 1
    # the part in the first block (6 samples) was too short alone: only the rest is flagged
    assert not got[:55].any()
    assert (got[55:] == expected[55:]).all()


def test_an_interval_is_cut_around_clipped_samples_or_dropped():
    rng = np.random.default_rng(2)
    values = np.r_[np.tile([0.0, 0.0, 9.8], (3000, 1)), np.tile([0.0, 9.8, 0.0], (1000, 1)),
                   np.tile([9.8, 0.0, 0.0], (300, 1))] + rng.normal(0, 0.01, (4300, 3))
    exclude = np.zeros(4300, dtype=bool)
    exclude[3500:3520] = True  # a knock inside the second hold: cut it in two
    exclude[4100:4250] = True  # most of the third hold: too short without them
    plain = detect_static(values, 100.0, init_static=20, min_length=1.0)
    found = detect_static(values, 100.0, init_static=20, min_length=1.0, exclude=exclude)
    assert len(plain) == 3
    assert len(found) == 3
    assert found.excluded["cut"] == 1
    assert found.excluded["dropped"] == 1
    assert not any(exclude[a:b].any() for a, b in zip(found.start, found.stop, strict=True))
    blocks = [Block(values[i:i + 700], i) for i in range(0, 4300, 700)]
    masks = iter(np.split(exclude, range(700, 4300, 700)))
    (streamed,) = detect_static_stream(blocks, 100.0, init_static=20, min_length=1.0,
                                       exclude=lambda _values: next(masks))
    assert (streamed.start == found.start).all()
    assert (streamed.stop == found.stop).all()
    assert {k: streamed.excluded[k] for k in ("cut", "dropped")} == {"cut": 1, "dropped": 1}


def test_the_fit_leaves_clipped_samples_out(triad):
    acc, t = triad
    clipped = np.minimum(acc, RAIL)
    kept = run(_recording(clipped, t), gravity=9.80665, factor=3.0, init_static=4)
    blind = run(_recording(clipped, t), gravity=9.80665, factor=3.0, init_static=4, rails=None)
    assert kept.intervals.excluded["dropped"] == 2
    assert len(kept.intervals) == 14
    scale = kept.reduction.sensors[0].values[3:6]
    assert np.allclose(scale, TRUTH.vector[3:6], atol=2e-4)  # within 200 ppm of the truth
    assert not np.allclose(blind.reduction.sensors[0].values[3:6], TRUTH.vector[3:6],
                           atol=2e-3)  # the clipped means pull the fit off
    found = {f["found"]: f for f in kept.reduction.provenance["repairs"]["found"]}
    assert found["static intervals dropped for clipped samples"]["count"] == 2
    assert any("dropped for clipped samples" in n for n in kept.reduction.notes)


def test_calibrate_reports_clipping_and_refuses_when_too_few_remain(tmp_path, capsys, triad):
    acc, t = triad
    path = _csv(tmp_path / "clipped.csv", np.minimum(acc, RAIL), t)
    base = ["triad", "calibrate", path, "--columns", "x,y,z", "--time", "t", "--unit",
            "m/s^2", "--gravity", "9.80665", "--factor", "3", "--init-static", "4"]
    code, _out, err = run_cli([*base, "--out", tmp_path / "cal.json", "--format", "json"],
                             capsys)
    assert code == 0, err
    assert "note: 2 static intervals dropped for clipped samples" in err
    assert "clipped samples (runs of 10 or more identical samples" in err
    twelve = simulate(TRUTH, 12, seed=3, still=5, dwell=3, motion=1, noise_sd=0.005)
    few = _csv(tmp_path / "twelve.csv", np.minimum(twelve.acc, RAIL), twelve.t - twelve.t[0])
    refused([*base[:2], few, *base[3:], "--out", tmp_path / "c12.json"], capsys,
            "8 position(s) given", "4 static interval(s) were dropped for clipped samples")


def test_detect_reports_clipping_and_rails_none_turns_it_off(tmp_path, capsys, triad):
    acc, t = triad
    path = _csv(tmp_path / "clipped.csv", np.minimum(acc, RAIL), t)
    base = ["triad", "calibrate", path, "--columns", "x,y,z", "--time", "t", "--unit",
            "m/s^2", "--gravity", "9.80665", "--factor", "3", "--init-static", "4"]
    code, _, err = run_cli(["triad", "detect", path, "--columns", "x,y,z", "--time", "t",
                            "--unit", "m/s^2", "--init-static", "4", "--factor", "3",
                            "--format", "json"], capsys)
    assert code == 0, err
    assert "note: 2 static intervals dropped for clipped samples" in err
    code, _, err = run_cli(["triad", "detect", path, "--columns", "x,y,z", "--time", "t",
                            "--unit", "m/s^2", "--init-static", "4", "--factor", "3",
                            "--rails", f"-20,{RAIL}"], capsys)
    assert code == 0, err
    assert "(runs of 3 or more at or beyond the rails -20, 9)" in err
    code, _, err = run_cli([*base, "--rails", "none", "--out", tmp_path / "c.json"], capsys)
    assert code == 0, err
    assert "clipped" not in err
    refused([*base, "--rails", "1,2,3", "--out", tmp_path / "c.json"], capsys, "LOW,HIGH")


def test_known_positions_leave_clipped_samples_out_of_their_means(tmp_path, capsys):
    six = simulate(TRUTH, 6, seed=1, still=5, dwell=3, motion=1, noise_sd=0.005)
    values = six.acc.copy()
    pos = six.positions[0]  # x up: clip a knock of 30 samples in its middle
    mid = (pos["start"] + pos["stop"]) // 2
    values[mid:mid + 30, 0] = values[:, 0].max() + 1.0
    rec = Recording(values, ("x", "y", "z"), "m/s^2", 100.0, six.t - six.t[0],
                    metadata={"positions": list(six.positions)})
    lab = run(rec, gravity=9.80665)
    found = {f["found"]: f for f in lab.reduction.provenance["repairs"]["found"]}
    assert found["clipped samples (runs of 10 or more identical samples at a channel's "
                 "extreme)"]["count"] == 30
    assert found["static intervals cut at clipped samples"]["count"] == 1
    assert np.allclose(lab.reduction.sensors[0].values[:6], TRUTH.vector[:6], atol=5e-3)
    assert json.dumps(lab.reduction.provenance["repairs"])  # JSON-ready
