"""Fuzz of the command line's arguments (issue 11): bad values exit 2 with one line, no traceback.

Every command of ``accelcal`` is found in the typer application
(:data:`accelcal.cli.app.app`); each of its options and arguments gets bad
values for its type (non-numbers, NaN, infinities, 1e308, -1, 0, 1e12,
huge lists, ranges like ``0:1e12:1``, empty strings, unknown choices;
inputs that are directories, missing, ``/dev/zero`` or under ``/proc``;
outputs that are directories, in missing directories, under ``/proc`` or
``/dev/full``), one at a time, on top of a valid invocation
(:data:`BASE`). Every run must end within :data:`TIME_LIMIT` seconds with

* exit status 2 and exactly one line on standard error starting
  ``accelcal: error: ``, or
* exit status 0 where the value is valid (a value marked ``must_fail``
  never is), with no non-finite number in its JSON output,

never a traceback and never a temporary file left beside an output.

The runs go through :func:`accelcal.cli.main` in a worker process (one per
command, so imports are paid once) with an address-space limit, so that a
run that hangs in compiled code or allocates without bound is killed and
reported instead of stopping the test suite. A command added later joins
by discovery; if it has required parameters it needs one line in
:data:`BASE`.
"""

import json
import os
import resource
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from helpers.cli import unstated_uncertainty
from helpers.paths import EXAMPLES, TESTS

pytestmark = pytest.mark.fuzz  # the whole module: the fuzz tier (docs/testing.md)

TIME_LIMIT = 20.0
"""Seconds one run may take."""

FIFO_TIME_LIMIT = 3.0
"""Seconds a run given a FIFO that nobody writes may take: it can only wait for ever, so the
matrix does not spend :data:`TIME_LIMIT` on each such hang."""

KILL_MARGIN = 5.0
"""Seconds past its limit after which a run that ignores SIGALRM (blocked in compiled code)
is killed with its worker."""

MAX_ERROR_CHARS = 1000
"""Longest error line accepted: a message quotes values shortened, not whole."""

MEMORY_LIMIT = 6 * 2**30
"""Address space of the worker process, bytes: an allocation beyond it fails at once."""

BASE: dict[str, list[str]] = {
    "demo": ["--out", "{out}/demo", "--seed", "1"],
    "report": ["{record}", "--out", "{out}/report.html"],
    "budget": ["{tumble}"],
    "certificate": ["{lone_record}", "--lab", "{lab}", "--out", "{out}/c.html", "--issued",
                    "2026-11-26"],
    "model show": [],
    "model new": ["--out", "{out}/model.json"],
    "model eval": ["--ai", "1"],
    "vre table": [],
    "vre simulate": ["--out", "{out}/v.csv", "--duration", "0.1", "--sample-rate", "1000"],
    "vre reduce": ["{examples}/vibrafuge.csv"],
    "vre fit": ["{examples}/vibrafuge.csv"],
    "transverse sweep": ["--amplitude", "5", "--angles", "0:330:30"],
    "transverse simulate": ["--out", "{out}/shaker"],
    "transverse analyze": ["{examples}/shaker"],
    "transverse fit": ["{examples}/shaker"],
    "dividing-head simulate": ["--out", "{out}/head.csv"],
    "dividing-head reduce": ["{examples}/indexing_head.csv"],
    "dividing-head study": ["--trials", "2"],
    "tumble identify": ["--points", "8"],
    "tumble simulate": ["--out", "{out}/tumble.csv"],
    "tumble reduce": ["{tumble}"],
    "triad detect": ["{examples}/triad.csv", "--init-static", "4"],
    "triad calibrate": ["{examples}/triad.csv", "--out", "{out}/cal.json"],
    "triad apply": ["{examples}/triad.csv", "--calibration", "{examples}/triad_calibration.json",
                    "--out", "{out}/o.csv"],
    "triad simulate": ["--out", "{out}/t.csv", "--still", "5", "--dwell", "2"],
    "triad plan": [],
    "noise adev": ["{examples}/still.csv"],
    "noise fit": ["{examples}/still.csv"],
    "noise psd": ["{examples}/still.csv"],
    "noise simulate": ["--N", "2e-5", "--rate", "100", "--duration", "10",
                       "--out", "{out}/still.csv"],
    "noise stability": ["--serial", "ACC-0001", "--db", "{store}"],
    "centrifuge simulate": ["--out", "{out}/c.csv", "--levels", "5:50:15"],
    "centrifuge reduce": ["{centrifuge}"],
    "centrifuge plan": ["--levels", "5:50:15", "--positions", "IA-in,IA-out,IA-tan"],
    "response simulate": ["--out", "{out}/r.csv", "--frequencies", "20,80,315"],
    "response reduce": ["{response}"],
    "response fit": ["{response}"],
    "response plan": [],
    "thermal simulate": ["--out", "{out}/th.csv", "--points", "8", "--dwell", "20", "--warmup",
                         "0", "--setpoints", "-20,10,40,25,-5"],
    "thermal reduce": ["{examples}/thermal.csv"],
    "thermal compensate": ["{examples}/thermal.csv", "--model",
                           "{examples}/thermal_compensation.json", "--out", "{out}/c.csv",
                           "--allow-extrapolation"],
    "acceptance simulate": ["--out", "{out}/steps.csv", "--dwell", "1"],
    "acceptance reduce": ["{steps}"],
    "acceptance compare": ["{record}", "{fixed}"],
    "acceptance repeatability": ["--serial", "R-1", "--db", "{store}"],
    "import": ["{examples}/still.csv", "--kind", "noise", "--channels", "acc=acc",
               "--out", "{out}/imported.csv"],
    "inspect": ["{examples}/still.csv"],
    "records add": ["{record}", "--db", "{out}/new.sqlite"],
    "records list": ["--db", "{store}"],
    "records history": ["ACC-0001", "--db", "{store}"],
    "records stats": ["ACC-0001", "--db", "{store}"],
    "records show": ["1", "--db", "{store}"],
    "records verify": ["--db", "{store}"],
    "records supersede": ["1", "--by", "{fixed}", "--who", "A. Tester", "--why", "a test",
                          "--db", "{store}"],
}
"""A valid invocation of each command (placeholders: ``{out}`` a fresh directory per run,
``{examples}`` examples/data, ``{record}`` a calibration record (``{fixed}`` a correction of
it, not stored), ``{tumble}`` a tumble
record, ``{centrifuge}`` a centrifuge record, ``{response}`` a response record, ``{store}``
a store holding the record and two noise fits). Commands without required parameters may be
left out (their base is empty)."""

LONG_BY_DESIGN: dict[tuple[str, str, str], str] = {
    ("dividing-head study", "trials", "1000000000000"):
        "studies stream in bounded memory: a huge trial count is a long run with progress "
        "(issue 11; --help says so), not an error",
}
"""(command, parameter, value) left out of the matrix, with the reason: runs that may
legitimately take longer than :data:`TIME_LIMIT`."""

SLOW_COMMANDS = {"demo": 3}
"""Commands whose runs take seconds: only this many bad values per option."""

# ------------------------------------------------------------------------- bad values
HUGE_LIST = ",".join(["1"] * 200_000)
MISSING = "{out}/missing/nothing.json"
DIRECTORY = "{out}"
FILE = "{out}/existing.json"
FIFO = "{out}/fifo"
FULL = "{out}/full"
ZERO = "{out}/zero"
NULL = "{out}/null"
"""Special paths made afresh in each run's directory (:func:`_special_files`): a file, a
FIFO nobody writes, and private device nodes like /dev/full, /dev/zero and /dev/null.
Outputs never go to the system's devices: run as root, an atomic writer that replaces its
target replaces the device node (it did: /dev/full became a regular file)."""

# (value, must_fail): must_fail values are never valid for the type
FLOAT_VALUES = [("abc", True), ("nan", True), ("inf", True), ("1e400", True), ("1e308", False),
                ("5e-324", False), ("-1", False), ("0", False), ("1e12", False)]
INT_VALUES = [("abc", True), ("1.5", True), ("-1", False), ("0", False),
              ("1000000000000", False), ("9" * 30, False)]
STR_VALUES = [("", False), ("bogus", False), ("nan", False), ("1e308", False), ("-1", False),
              ("0:1e12:1", False), ("1:0:1", False), (HUGE_LIST, False),
              ("x" * 100_000, False), ("\x1b[31m\x00", False)]
CHOICE_VALUES = [("bogus", True), ("", True), ("JSON ", True)]
INPUT_VALUES = [(DIRECTORY, True), (MISSING, True), (ZERO, True), (NULL, True), (FIFO, True),
                ("/proc/self/mem", True), ("", True)]
INPUT_DIRECTORY_VALUES = [(MISSING, True), (FILE, True), (NULL, True), (FIFO, True), ("", False),
                          (DIRECTORY, False)]
"""An input directory: "" is the working directory (a Path of "")."""
OUTPUT_VALUES = [(DIRECTORY, True), (MISSING, True), ("/proc/accelcal-fuzz/x", True),
                 (FULL, True), (FIFO, True), ("", True)]
DIRECTORY_OUTPUT_VALUES = [(NULL, True), ("/proc/accelcal-fuzz", True), (FILE, True),
                           (FULL, True)]
STORE_VALUES = [(DIRECTORY, True), (FILE, True), (FIFO, True), ("notaurl://x", True),
                ("{out}/missing/store.sqlite", False)]
"""No device links here: SQLite resolves a link and makes its journal beside the target
(/dev/zero-journal)."""

KINDS: dict[str, str] = {
    # parameter name -> kind, where the annotation alone does not tell
    "out": "output", "record_out": "output", "plot": "output-dir", "db": "store",
    "fmt": "choice", "method": "choice", "route": "choice", "estimator": "choice",
    "axial": "choice", "sampling": "choice", "axis": "choice", "uncertainty": "choice",
    "covariance": "choice", "scheduler": "str", "imucal_out": "output",
}
"""Parameter name -> kind of bad values (else from its annotation: float, int, str, Path)."""

COMMAND_KINDS: dict[tuple[str, str], str] = {
    ("records history", "method"): "str", ("records stats", "method"): "str",
    ("transverse simulate", "out"): "output-dir", ("demo", "out"): "output-dir",
    ("report", "data"): "input-dir", ("budget", "data"): "input-dir",
    ("records supersede", "by"): "input", ("certificate", "data"): "input-dir",
}
"""(command, parameter) -> kind, where the parameter name means something else there."""

VALUES = {"float": FLOAT_VALUES, "int": INT_VALUES, "str": STR_VALUES,
          "choice": CHOICE_VALUES, "input": INPUT_VALUES, "input-dir": INPUT_DIRECTORY_VALUES,
          "output": OUTPUT_VALUES,
          "output-dir": DIRECTORY_OUTPUT_VALUES, "store": STORE_VALUES}


def commands() -> dict[str, object]:
    """Every leaf command of the application: ``"group command"`` -> click command."""
    import typer

    from accelcal.cli.app import app

    found = {}

    def walk(cmd, path):
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                walk(sub, [*path, name])
        else:
            found[" ".join(path)] = cmd

    walk(typer.main.get_command(app), [])
    return found


def _kind(command: str, param) -> str | None:
    if (command, param.name) in COMMAND_KINDS:
        return COMMAND_KINDS[(command, param.name)]
    if param.name in KINDS:
        return KINDS[param.name]
    if getattr(param, "is_flag", False):
        return None
    annotation = param.type_descriptor.annotation
    text = str(annotation)
    if "Path" in text:
        return "input"
    for name in ("float", "int", "str"):
        if name in text:
            return name
    return None


def cases() -> list[dict]:
    """The matrix: one case per (command, parameter, bad value)."""
    out = []
    for name, cmd in commands().items():
        base = BASE.get(name, [])
        limit = SLOW_COMMANDS.get(name)
        for param in cmd.params:
            kind = _kind(name, param)
            if kind is None:
                continue
            values = VALUES[kind][:limit] if limit else VALUES[kind]
            for value, must_fail in values:
                if (name, param.name, value) in LONG_BY_DESIGN:
                    continue
                args = _replace(base, param, value)
                out.append({"command": name, "param": param.name, "value": value,
                            "must_fail": must_fail, "args": [*name.split(), *args],
                            "limit": FIFO_TIME_LIMIT if value == FIFO else TIME_LIMIT})
    return out


def _replace(base: list[str], param, value: str) -> list[str]:
    """``base`` with ``param`` set to ``value`` (replacing the base's value if any)."""
    args = list(base)
    if getattr(param, "param_type_name", "") == "argument":
        positional = [i for i, a in enumerate(args)
                      if not a.startswith("--") and (i == 0 or not args[i - 1].startswith("--"))]
        if positional:
            args[positional[0]] = value
            return args
        return [value, *args]
    opt = param.opts[0]
    if opt in args:
        i = args.index(opt)
        del args[i:i + 2]
    return [*args, f"{opt}={value}"]


# ------------------------------------------------------------------------------- worker
def _worker(cases_file: str, results_file: str, root: str) -> None:
    """Run the cases of ``cases_file`` in this process, one JSON line per case start/end."""
    import contextlib
    import io
    import warnings

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    os.environ["ACCELCAL_DB"] = str(Path(root) / "default-store.sqlite")  # never the user's
    from accelcal.cli import main

    class Timeout(BaseException):
        pass

    def alarm(signum, frame):
        raise Timeout

    signal.signal(signal.SIGALRM, alarm)
    todo = json.loads(Path(cases_file).read_text())
    with open(results_file, "a") as log:
        for case in todo:
            out = Path(root) / f"case{case['index']}"
            out.mkdir()
            _special_files(out)
            fill = {"out": str(out), "examples": str(EXAMPLES), **case["fill"]}
            args = [_subst(a, fill) for a in case["args"]]
            log.write(json.dumps({"start": case["index"]}) + "\n")
            log.flush()
            stdout, stderr = io.StringIO(), io.StringIO()
            code, problem = None, None
            start = time.perf_counter()
            signal.setitimer(signal.ITIMER_REAL, case["limit"])
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
                        main(args)
                except SystemExit as exc:
                    code = exc.code
                except Timeout:
                    problem = f"no answer within {case['limit']} s"
                except BaseException as exc:
                    import traceback

                    lines = traceback.format_exception(exc)
                    problem = (f"{type(exc).__name__} escaped main(): "
                               + " | ".join(x.strip().replace("\n", " ") for x in lines[-3:]))
                finally:
                    signal.setitimer(signal.ITIMER_REAL, 0)
            seconds = time.perf_counter() - start
            if problem is None and caught:
                w = caught[0]
                problem = (f"warning {w.category.__name__}: {w.message} "
                           f"({Path(w.filename).name}:{w.lineno})")
            leftovers = [str(p) for p in out.rglob("*") if ".tmp" in p.name]
            replaced = [p.name for p in (out / "full", out / "zero", out / "null", out / "fifo")
                        if not (p.is_symlink() or p.is_fifo() or p.is_char_device())]
            log.write(json.dumps({"done": case["index"], "code": code, "problem": problem,
                                  "stdout": stdout.getvalue()[-4000:],
                                  "stderr": _clip(stderr.getvalue()),
                                  "stderr_chars": len(stderr.getvalue()),
                                  "stderr_lines": stderr.getvalue().count("\n"),
                                  "seconds": seconds, "leftovers": leftovers,
                                  "replaced": replaced}) + "\n")
            log.flush()


def _special_files(out: Path) -> None:
    """The run's special files: private device nodes where the process may make them (root),
    else a FIFO for ``full`` (an output: never a link to a real device) and links to
    /dev/zero and /dev/null (read, or a directory that cannot be made)."""
    (out / "existing.json").write_text("{}")
    os.mkfifo(out / "fifo")
    for name, minor in (("full", 7), ("zero", 5), ("null", 3)):
        try:
            os.mknod(out / name, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        except OSError:
            if name == "full":
                os.mkfifo(out / name)
            else:
                (out / name).symlink_to(f"/dev/{name}")


def _clip(text: str, n: int = 1000) -> str:
    return text if len(text) <= 2 * n else text[:n] + " [...] " + text[-n:]


def _subst(arg: str, fill: dict) -> str:
    for key, value in fill.items():
        arg = arg.replace("{" + key + "}", value)
    return arg


def run_cases(todo: list[dict], tmp: Path) -> dict[int, dict]:
    """Run ``todo`` in worker processes; a worker that stops answering is killed, its case
    reported as a hang, and a new worker takes the rest."""
    results: dict[int, dict] = {}
    remaining = list(todo)
    round_ = 0
    while remaining:
        round_ += 1
        cases_file, results_file = tmp / f"cases{round_}.json", tmp / f"results{round_}.jsonl"
        cases_file.write_text(json.dumps(remaining))
        results_file.write_text("")
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
               "MKL_NUM_THREADS": "1", "COLUMNS": "200",
               "PYTHONPATH": os.pathsep.join(filter(None, [str(TESTS),
                                                           os.environ.get("PYTHONPATH")]))}
        errors = tmp / f"worker{round_}.stderr"
        with open(errors, "w") as err_fh:
            proc = subprocess.Popen(
                [sys.executable, __file__, "worker", str(cases_file), str(results_file),
                 str(tmp)], env=env, stdout=subprocess.DEVNULL, stderr=err_fh)
        limits = {c["index"]: c["limit"] for c in remaining}
        started_at, current, hung = time.monotonic(), None, False
        while True:
            try:
                proc.wait(timeout=0.2)
                break
            except subprocess.TimeoutExpired:
                pass
            starts = [json.loads(line)["start"] for line in
                      results_file.read_text().splitlines() if line.startswith('{"start"')]
            if starts and starts[-1] != current:
                current, started_at = starts[-1], time.monotonic()
            if (current is not None
                    and time.monotonic() - started_at > limits[current] + KILL_MARGIN):
                hung = True
                proc.kill()
                proc.wait()
                break
        done = set()
        last_start = None
        for line in results_file.read_text().splitlines():
            rec = json.loads(line)
            if "done" in rec:
                results[rec["done"]] = rec
                done.add(rec["done"])
            else:
                last_start = rec["start"]
        if last_start is not None and last_start not in done:
            results[last_start] = {
                "done": last_start, "code": None, "stdout": "",
                "stderr": errors.read_text()[-1000:], "stderr_chars": 0, "stderr_lines": 0,
                "problem": (f"no answer within {limits[last_start] + KILL_MARGIN} s, not even to "
                            "SIGALRM (blocked in compiled code; the worker was killed)") if hung
                else f"the worker process died (exit {proc.returncode}): "
                     f"{errors.read_text()[-300:]!r}",
                "seconds": None, "leftovers": [], "replaced": []}
            done.add(last_start)
        elif proc.returncode and not done:
            raise RuntimeError(errors.read_text()[-2000:])
        remaining = [c for c in remaining if c["index"] not in done]
    return results


def judge(case: dict, res: dict) -> str | None:
    """What is wrong with a run, or None."""
    if res["problem"]:
        return res["problem"]
    code, err = res["code"], res["stderr"]
    if "Traceback" in err or "Traceback" in res["stdout"]:
        return f"traceback on stderr: {err[-300:]!r}"
    if res["leftovers"]:
        return f"temporary files left: {res['leftovers']}"
    if res["replaced"]:
        name = res["replaced"][0]
        what = "a FIFO" if name == "fifo" else f"a device node like /dev/{name}"
        return (f"replaced {name!r} ({what}) with a regular file, exit {code}: given "
                "/dev/full itself, it replaces the system's device node")
    if code == 2:
        if not err.startswith("accelcal: error: ") or res["stderr_lines"] != 1:
            return f"exit 2 but stderr is not one error line: {err[:300]!r}"
        if res["stderr_chars"] > MAX_ERROR_CHARS:
            return (f"exit 2 with an error line of {res['stderr_chars']} characters (the value "
                    f"echoed unbounded?): {err[:150]!r}")
        return None
    if code not in (0, None):
        return f"exit {code}: {err[-300:]!r}"
    if case["must_fail"]:
        return f"exit 0 on an invalid value (stderr {err[-200:]!r})"
    for token in ("NaN", "Infinity"):
        if token in res["stdout"]:
            i = res["stdout"].index(token)
            return f"exit 0 with {token} in the output: ...{res['stdout'][max(0, i - 80):i + 20]!r}"
    return unstated_uncertainty(res["stdout"])


def _fill(tmp: Path) -> dict:
    """Shared input files of the matrix: a calibration record, tumble and step records, a store
    (the record, two noise fits of ACC-0001, four tumble calibrations of R-1)."""
    from accelcal.cli import main

    record = EXAMPLES / "calibration_record.json"
    tumble, store = tmp / "tumble.csv", tmp / "store.sqlite"
    centrifuge, steps = tmp / "centrifuge.csv", tmp / "steps.csv"
    response = tmp / "response.csv"
    runs = [["tumble", "simulate", "--out", str(tumble), "--points", "12"],
            ["acceptance", "simulate", "--out", str(steps), "--increments", "1,3,6"],
            ["response", "simulate", "--out", str(response), "--frequencies", "20,80,315,630"],
            ["centrifuge", "simulate", "--out", str(centrifuge), "--levels", "5:50:15",
             "--readings", "2"],
            ["records", "add", str(record), "--db", str(store)]]
    for seed in ("1", "2"):  # two still recordings of ACC-0001: `noise stability` needs two
        still, fit = tmp / f"still{seed}.csv", tmp / f"noise{seed}.json"
        runs += [["noise", "simulate", "--N", "2e-5", "--B", "3e-6", "--rate", "50",
                  "--duration", "20", "--seed", seed, "--out", str(still)],
                 ["noise", "fit", str(still), "--terms", "N,B,K", "--record", str(fit),
                  "--serial", "ACC-0001"],
                 ["records", "add", str(fit), "--db", str(store)]]
    for seed in ("1", "2"):  # four tumble calibrations of R-1: `acceptance repeatability`
        pair = tmp / f"env{seed}.json"
        runs += [["acceptance", "simulate", "--test", "environment", "--shift", "K0=0ug",
                  "--serial", "R-1", "--seed", seed, "--out", str(pair)],
                 ["records", "add", str(tmp / f"env{seed}-before.json"),
                  str(tmp / f"env{seed}-after.json"), "--db", str(store)]]
    for args in runs:
        with pytest.raises(SystemExit) as info:
            main(args)
        assert info.value.code == 0, args
    fixed = tmp / "fixed.json"
    fixed.write_text(record.read_text().replace('"operator": "', '"operator": "corrected ', 1))
    # the record away from its input files: its budget keeps the record's own numbers (the
    # budget engine's re-runs of the reduction, seconds each, are not what is fuzzed here)
    lone = tmp / "lone_record.json"
    lone.write_bytes(record.read_bytes())
    return {"record": str(record), "fixed": str(fixed), "lone_record": str(lone),
            "lab": str(EXAMPLES.parent / "lab.toml"),
            "tumble": str(tumble), "store": str(store),
            "centrifuge": str(centrifuge), "steps": str(steps),
            "response": str(response)}


def _matrix():
    all_cases = cases()
    for i, case in enumerate(all_cases):
        case["index"] = i
    return all_cases


MATRIX = _matrix()
GROUPS = sorted({c["command"] for c in MATRIX})


@pytest.mark.slow
@pytest.mark.parametrize("command", GROUPS)
def test_bad_arguments_exit_2_with_one_line(command, tmp_path, capsys):
    fill = _fill(tmp_path)
    capsys.readouterr()
    todo = [{**c, "fill": fill} for c in MATRIX if c["command"] == command]
    results = run_cases(todo, tmp_path)
    failures = []
    for case in todo:
        problem = judge(case, results[case["index"]])
        if problem:
            shown = " ".join(a if len(a) < 60 else a[:25] + f"...({len(a)} chars)"
                             for a in case["args"])
            failures.append(f"accelcal {shown}: {problem}")
    assert not failures, f"{len(failures)} of {len(todo)} runs failed:\n" + "\n".join(failures)


def test_every_command_is_in_the_matrix():
    found = commands()
    assert set(GROUPS) == {n for n, c in found.items()
                           if any(_kind(n, p) for p in c.params)}
    for name, cmd in found.items():
        required = [p.name for p in cmd.params if p.required]
        if required:
            assert name in BASE, f"{name}: add a valid invocation to BASE (requires {required})"
    assert set(BASE) <= set(found), set(BASE) - set(found)


def test_every_parameter_has_a_kind():
    for name, cmd in commands().items():
        for param in cmd.params:
            if param.name == "help" or getattr(param, "is_flag", False):
                continue
            assert _kind(name, param) is not None, (name, param.name)


def test_base_invocations_are_valid(tmp_path, capsys):
    from accelcal.cli import main

    fill = {**_fill(tmp_path), "examples": str(EXAMPLES)}
    for name, base in BASE.items():
        if name in SLOW_COMMANDS:
            continue
        out = tmp_path / name.replace(" ", "-")
        out.mkdir()
        args = [*name.split(), *(_subst(a, {**fill, "out": str(out)}) for a in base)]
        with pytest.raises(SystemExit) as info:
            main(args)
        _, err = capsys.readouterr()
        assert info.value.code == 0, (args, err)


if __name__ == "__main__" and sys.argv[1:2] == ["worker"]:
    _worker(*sys.argv[2:5])
