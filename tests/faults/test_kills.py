"""Every writing command killed at a random point: one line, its exit status, nothing left.

Each case starts a command in a child process, sends it a signal after a
delay drawn from a seeded generator (start-up, reading, computing, writing,
or after it ended), then runs the same command again to another output in
the same directory (and the same ``TMPDIR``). It asserts:

- no traceback, and the exit status the signal states (130 SIGINT, 143
  SIGTERM, 129 SIGHUP, killed by SIGKILL; 0 if it had ended; a run killed
  by SIGTERM or SIGHUP before Python ran accelcal's code dies silently);
- the output is either absent or whole: byte for byte the next run's (the
  report, which carries its time, ends its HTML);
- after the next run, no temporary of accelcal's is left, beside the output
  or in ``TMPDIR`` (those of a SIGKILLed run are removed by the next run).
"""

import random
import signal

import pytest

from helpers.faults import EXIT, kill_after, leftovers, run

pytestmark = pytest.mark.faults

COMMANDS = {
    "triad simulate": (["triad", "simulate", "--seed", "3", "--dwell", "100", "--out"], ".csv"),
    "thermal simulate": (["thermal", "simulate", "--seed", "3", "--out"], ".csv"),
    "import": (["import", "{t.csv}", "--kind", "noise", "--channels", "acc=acc_x", "--out"],
               ".parquet"),
    "triad apply": (["triad", "apply", "{t.csv}", "--calibration", "{cal.json}", "--out"],
                    ".csv"),
    "thermal compensate": (["thermal", "compensate", "{th.csv}", "--model", "{comp.json}",
                            "--column", "output", "--temperature-column", "temperature",
                            "--out"], ".csv"),
    "noise adev": (["noise", "adev", "{n.parquet}", "--format", "csv"], None),
    "report": (["report", "{rec.json}", "--out"], ".html"),
}
"""Command -> (arguments, the output's suffix, appended after the last argument; None: stdout)."""

SIGNALS = {
    "triad simulate": (signal.SIGKILL, signal.SIGTERM, signal.SIGINT),
    "thermal simulate": (signal.SIGKILL, signal.SIGHUP),
    "import": (signal.SIGKILL, signal.SIGTERM, signal.SIGHUP),
    "triad apply": (signal.SIGKILL, signal.SIGTERM, signal.SIGINT),
    "thermal compensate": (signal.SIGKILL, signal.SIGHUP),
    "noise adev": (signal.SIGKILL, signal.SIGTERM, signal.SIGINT),
    "report": (signal.SIGKILL, signal.SIGTERM),
}
"""The signals each command is killed with (every signal for every kind of writer)."""

CASES = [(c, s) for c, sigs in SIGNALS.items() for s in sigs]


def _args(command: str, inputs, out):
    args, suffix = COMMANDS[command]
    filled = [str(inputs / a[1:-1]) if a.startswith("{") else a for a in args]
    return filled + ([str(out) + suffix] if suffix else [])


@pytest.mark.parametrize(("command", "sig"), CASES, ids=[f"{c}-{s.name}" for c, s in CASES])
def test_killed_at_a_random_point(command, sig, inputs, tmp_path):
    work, tmpdir = tmp_path / "out", tmp_path / "tmp"
    work.mkdir()
    delay = random.Random(f"{command}/{sig.name}").uniform(0.3, 4.0)
    killed, _ = kill_after(_args(command, inputs, work / "killed"), delay, sig, cwd=work,
                           tmpdir=tmpdir)
    assert not killed.traceback, killed.err
    if killed.code == 0:
        expected = {0}
    elif sig == signal.SIGKILL:
        expected = {-signal.SIGKILL}
    else:
        # -sig: killed before Python ran accelcal's code, or as the process exited after
        # its work (accelcal.cli.signals.done: the output is then whole, checked below)
        expected = {EXIT[sig], -sig}
        said = [line for line in killed.err.splitlines()  # what the run said before the signal
                if line.strip() and not line.startswith(("note:", "accelcal: note:", "wrote "))]
        assert len(said) <= 1, killed.err
        assert not said or said[0].startswith(("accelcal: interrupted", "accelcal: stopped by"))
    assert killed.code in expected, (delay, killed.code, killed.err)
    following = run(_args(command, inputs, work / "next"), cwd=work, tmpdir=tmpdir)
    assert following.code == 0, following.err
    assert leftovers(work, tmpdir) == []
    suffix = COMMANDS[command][1]
    late = killed.code == -sig and killed.err.strip()  # after its work: the output whole
    if suffix is None:
        if killed.code == 0 or late:
            assert killed.out == following.out
        return
    if late:
        assert (work / f"killed{suffix}").exists(), killed.err
    out, reference = work / f"killed{suffix}", work / f"next{suffix}"
    if out.exists():
        if suffix == ".html":
            assert out.read_text().rstrip().endswith("</html>")
        else:
            assert out.read_bytes() == reference.read_bytes()
    else:
        assert killed.code != 0
