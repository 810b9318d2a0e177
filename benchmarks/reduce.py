"""Reductions, record files, the demo and start-up, against honest floors (issue 16).

Run from the repository root (about 3-4 minutes)::

    python benchmarks/reduce.py                     # every section
    python benchmarks/reduce.py sinefit records     # some sections
    python benchmarks/reduce.py vre --pythonpath /path/to/other/src   # another source tree

Sections:

- ``sinefit``: the three-parameter fit of one record of 1e6 samples, the
  public call timed whole (a new time base each call: design and set-up
  included) and with its time base cached (records sharing one), against
  one read of the same array (``np.sum``) and against ``curve_fit`` on the
  same record (also whole); coherent (137 Hz at 20 kHz: 137 periods in
  20000 samples) and not (137.1234 Hz).
- ``vre``: VRE identification with its Monte Carlo uncertainty
  (``accelcal vre fit --uncertainty mc``: :func:`~accelcal.methods.vre.identify`
  then :func:`~accelcal.methods.vre.vre_uncertainty`) on 1,173 and 11,703
  points, each in a fresh subprocess: wall time and peak resident memory.
- ``records``: a record of 1e6 rows x 4 columns written and read as CSV and
  Parquet by :mod:`accelcal.io.records`, against pyarrow writing and reading
  the same table (and the former ``np.savetxt`` writer).
- ``response``: a stepped-sine comparison of 20 steps (10 Hz to 1.25 kHz),
  two channels at 10 kHz, 2 s per step (4e5 samples per channel), reduced
  in memory (:func:`~accelcal.methods.response.reduce_stepped`) against one
  read of its samples from its record file (Parquet, the floor; CSV beside).
- ``figures``: a log-log spectrum of 32768 points drawn to SVG whole and
  decimated to 1/32 (whether the points cost anything).
- ``demo``: ``accelcal demo`` wall time (in-process in a subprocess) and the
  share of the report's figures (building and SVG rendering).
- ``help``: ``accelcal --help`` against ``python -c "import numpy"``, both
  as subprocesses.

Every figure is the median of at least 5 interleaved repeats, printed with
its ratio to the section's floor and the 1-minute load average before the
runs; figures taken with a load above 0.5 per core are flagged "under load"
(their ratios are less trustworthy; rerun on an idle machine).
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: I001  (first: it pins BLAS to one thread before numpy loads)

import numpy as np

ROOT = common.ROOT
PYTHON = sys.executable


def _children_cpu(candidates: dict) -> tuple[dict, dict]:
    """Candidates that also record their subprocesses' CPU time, and where it goes."""
    import resource

    spent: dict = {name: [] for name in candidates}

    def wrap(name, fn):
        def run():
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            fn()
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            spent[name].append(after.ru_utime + after.ru_stime
                               - before.ru_utime - before.ru_stime)
        return run

    return {name: wrap(name, fn) for name, fn in candidates.items()}, spent


def _timed(candidates: dict, repeats: int) -> tuple[dict, dict]:
    """:func:`common.interleaved` of subprocess candidates, CPU times those of the children."""
    wrapped, spent = _children_cpu(candidates)
    detail: dict = {}
    runs = common.interleaved(wrapped, repeats, detail=detail)
    for name, cpu in spent.items():
        detail[name].cpu = cpu
    return runs, detail


def _env(pythonpath: str | None) -> dict:
    env = dict(os.environ)
    if pythonpath:
        env["PYTHONPATH"] = pythonpath
    return env


def bench_sinefit(report: common.Report, repeats: int, **_) -> None:
    from scipy.optimize import curve_fit

    from accelcal.signal import sinefit

    n, fs = 1_000_000, 20_000.0
    rng = np.random.default_rng(1)
    t = np.arange(n) / fs
    for f, label in ((137.0, "coherent, 137 Hz"), (137.1234, "not coherent, 137.1234 Hz")):
        y = 0.1 + 1.3 * np.sin(2 * np.pi * f * t + 0.7) + rng.normal(0, 1e-3, n)

        def model(tt, c, a, b, f=f):
            return c + a * np.cos(2 * np.pi * f * tt) + b * np.sin(2 * np.pi * f * tt)

        def whole(y=y, f=f):
            cache = getattr(sinefit, "_cached_fit", None)  # absent before the cache existed
            if cache is not None:
                cache.cache_clear()  # a new time base: set-up included
            return sinefit.sine_fit3(y, fs, f)

        def by_curve_fit(y=y, model=model):
            return curve_fit(model, t, y, p0=(0.0, 0.0, 1.0))[0]

        detail: dict = {}
        runs = common.interleaved({
            "read once (np.sum, floor)": lambda y=y: np.sum(y),
            "sine_fit3 whole (new time base)": whole,
            "sine_fit3 (time base cached)": lambda y=y, f=f: sinefit.sine_fit3(y, fs, f),
            "curve_fit whole": by_curve_fit,
        }, repeats, detail=detail)
        ours, theirs = whole().parameters, by_curve_fit()
        agree = float(np.max(np.abs(ours - theirs)) / np.max(np.abs(theirs)))
        rows = common.figures(runs, detail, floor="read once (np.sum, floor)",
                              notes={"curve_fit whole": f"max rel. difference {agree:.1g}"})
        report.add(common.markdown(rows, f"Sine fit, 1e6 samples, {label}", "one read"))


_VRE = """
import json, resource, sys, time
import numpy as np
from accelcal.methods.vre import identify, vre_columns, vre_uncertainty
n, trials = int(sys.argv[1]), int(sys.argv[2])
rng = np.random.default_rng(1)
b = rng.uniform(-20, 20, n)
a = rng.uniform(0, 30, n)
cols = vre_columns(b[:, None] * np.array([1.0, 0.0, 0.0]), a)
y = (1e-5 * cols["K2"] + 2e-6 * cols["K3"] + 1e-4 * cols["K0_asym"] + 1e-4 * cols["K1_asym"]
     + rng.normal(0, 1e-6, n))
start = time.perf_counter()
red = identify(b, a, y, np.full(n, 1e-6))
mid = time.perf_counter()
mc = vre_uncertainty(red, trials=trials, seed=1, amplitude_sd=0.01)
end = time.perf_counter()
print(json.dumps({"identify": mid - start, "total": end - start,
                  "rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def bench_vre(report: common.Report, repeats: int, pythonpath=None, **_) -> None:
    trials, out = 1000, {}

    def run(n, t=trials):
        out.setdefault((n, t), []).append(common.child_json(_VRE, n, t, env=_env(pythonpath)))

    _, detail = _timed({"1,173 points": lambda: run(1173),
                        "11,703 points": lambda: run(11703)}, repeats)
    # the subprocess's own clock (no interpreter start-up) for the ratio
    inner = {name: [r["total"] for r in out[(n, trials)]]
             for name, n in (("1,173 points", 1173), ("11,703 points", 11703))}
    rows = common.figures(inner, detail, floor="1,173 points", notes={
        name: (f"identify alone {common.median([r['identify'] for r in out[(n, trials)]]):.3g} s;"
               f" peak RSS {max(r['rss_mib'] for r in out[(n, trials)]):.0f} MiB")
        for name, n in (("1,173 points", 1173), ("11,703 points", 11703))})
    report.add(common.markdown(
        rows, f"VRE identification + Monte Carlo ({trials} trials), time in the subprocess",
        "1,173 points"))
    run(11703, 4096)  # one block of the default 4096 trials: the largest memory a fit takes
    worst = out[(11703, 4096)][0]
    report.add(common.pairs([
        ("peak RSS, 11,703 points, 4096 trials (one full block)", f"{worst['rss_mib']:.0f} MiB"),
        ("wall time of that run", f"{worst['total']:.3g} s"),
        ("source", pythonpath or "this checkout")], "VRE memory, worst case"))


def bench_records(report: common.Report, repeats: int, **_) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq
    from pyarrow import csv

    from accelcal.io.records import read_record, write_record

    rng = np.random.default_rng(2)
    rows = 1_000_000
    cols = {"t": np.arange(rows) / 2000.0, **{c: rng.normal(size=rows) for c in "uvw"}}
    meta = {"units": {"t": "s", "u": "V", "v": "V", "w": "V"}}
    table = pa.table(cols)
    opts = csv.WriteOptions(include_header=False, quoting_style="none")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)

        def arrow_csv_write():
            with open(d / "arrow.csv", "wb") as fh:
                fh.write(b"# accelcal record\n# {}\nt,u,v,w\n")
                csv.write_csv(table, fh, opts)

        def savetxt():
            with open(d / "old.csv", "w") as fh:
                np.savetxt(fh, np.column_stack(list(cols.values())), delimiter=",", fmt="%.17g")

        write_record(d / "r.csv", "bench", meta, cols)
        write_record(d / "r.parquet", "bench", meta, cols)
        arrow_csv_write()
        names = list(cols)
        read_opts = csv.ReadOptions(column_names=names, skip_rows=3)
        convert = csv.ConvertOptions(column_types=dict.fromkeys(names, pa.float64()))
        groups = {
            "CSV write": {
                "pyarrow write_csv (floor)": arrow_csv_write,
                "accelcal write_record": lambda: write_record(d / "r.csv", "bench", meta, cols),
                "np.savetxt (former writer)": savetxt},
            "CSV read": {
                "pyarrow read_csv (floor)": lambda: csv.read_csv(
                    d / "arrow.csv", read_options=read_opts, convert_options=convert),
                "accelcal read_record": lambda: read_record(d / "r.csv", "bench")},
            "Parquet write": {
                "pyarrow write_table (floor)": lambda: pq.write_table(table, d / "a.parquet"),
                "accelcal write_record": lambda: write_record(
                    d / "r.parquet", "bench", meta, cols)},
            "Parquet read": {
                "pyarrow read_table (floor)": lambda: pq.read_table(d / "a.parquet"),
                "accelcal read_record": lambda: read_record(d / "r.parquet", "bench")},
        }
        for title, candidates in groups.items():
            detail: dict = {}
            runs = common.interleaved(candidates, repeats, detail=detail)
            report.add(common.markdown(common.figures(runs, detail, floor=next(iter(candidates))),
                                       f"Record files, {title}: {rows} rows x 4 columns",
                                       "pyarrow"))


def bench_figures(report: common.Report, repeats: int, **_) -> None:
    import io

    from accelcal.plotting import new_figure
    from accelcal.report import figure_svg

    f = np.linspace(0.0, 50.0, 32_769)[1:]
    p = 1e-9 * (1 + 0.3 / f) * np.random.default_rng(3).exponential(size=f.size)

    def draw(x, y, svg=lambda fig: fig.savefig(io.StringIO(), format="svg")):
        fig = new_figure(figsize=(6.0, 4.2))
        ax = fig.add_subplot()
        ax.loglog(x, y, lw=0.6)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("PSD (g²/Hz)")
        ax.grid(True, which="both", alpha=0.3)
        svg(fig)

    draw(f, p)  # matplotlib's first-figure costs outside the timings
    detail: dict = {}
    runs = common.interleaved({
        "32768 points": lambda: draw(f, p),
        "1024 points (every 32nd)": lambda: draw(f[::32], p[::32]),
        "1024 points, plain-text log labels (figure_svg)": lambda: draw(f[::32], p[::32],
                                                                         figure_svg),
    }, repeats, detail=detail)
    report.add(common.markdown(common.figures(runs, detail, floor="32768 points"),
                               "A log-log spectrum to SVG: whole, decimated, and labelled "
                               "without math text (matplotlib's labels are math text)",
                               "whole"))


_DEMO = """
import json, shutil, sys, tempfile, time
start = time.perf_counter()
import accelcal.report.sections as rs
import accelcal.results as res
acc = {"build": 0.0, "svg": 0.0}
svg0, fig0 = rs.figure_svg, res.Reduction.figures
def figure_svg(fig):
    t = time.perf_counter(); out = svg0(fig); acc["svg"] += time.perf_counter() - t; return out
def figures(self, **kw):
    t = time.perf_counter(); out = fig0(self, **kw); acc["build"] += time.perf_counter() - t
    return out
rs.figure_svg, res.Reduction.figures = figure_svg, figures
from accelcal.demo import run
out = tempfile.mkdtemp()
try:
    r = run(out, seed=1, progress=False)
finally:
    shutil.rmtree(out, ignore_errors=True)
print(json.dumps({"wall": time.perf_counter() - start, "run": r.seconds,
                  "figures": len(r.figures), **acc}))
"""


def bench_response(report: common.Report, repeats: int, **_) -> None:
    from accelcal.io.formats.response import ResponseRecord, read, write
    from accelcal.methods.response import reduce_stepped
    from accelcal.rigs.shaker_response import simulate

    freqs = np.round(np.geomspace(10.0, 1250.0, 20), 1)
    parts = [simulate(frequencies=(f,), periods=round(2 * f), sample_rate=10000.0, seed=k)
             for k, f in enumerate(freqs)]
    cols = {c: np.concatenate([getattr(p, c) + (k if c == "step" else 0)
                               for k, p in enumerate(parts)])
            for c in ("step", "frequency", "t", "ref", "dut")}
    rec = ResponseRecord(**cols, sample_rate_hz=10000.0,
                         metadata={**parts[0].metadata, "amplitudes_g": [1.0] * len(freqs)})
    with tempfile.TemporaryDirectory() as tmp:
        write(Path(tmp) / "r.parquet", rec)
        write(Path(tmp) / "r.csv", rec)
        reduce_stepped(rec)
        detail: dict = {}
        runs = common.interleaved({
            "read its record (Parquet, floor)": lambda: read(Path(tmp) / "r.parquet"),
            "read its record (CSV)": lambda: read(Path(tmp) / "r.csv"),
            "reduce_stepped (in memory)": lambda: reduce_stepped(rec),
        }, repeats, detail=detail)
    report.add(common.markdown(common.figures(runs, detail,
                                              floor="read its record (Parquet, floor)"),
                               f"Stepped-sine comparison, 20 steps x 2 s, two channels at 10 "
                               f"kHz ({rec.ref.size} samples each)", "one read"))


def bench_demo(report: common.Report, repeats: int, pythonpath=None, **_) -> None:
    out = []

    def demo():
        out.append(common.child_json(_DEMO, env=_env(pythonpath)))

    runs, detail = _timed({"accelcal demo (process wall time)": demo}, repeats)
    med = {k: common.median([o[k] for o in out]) for k in ("wall", "run", "build", "svg")}
    rows = common.figures(runs, detail, notes={
        "accelcal demo (process wall time)":
            f"{out[0]['figures']} figures: building {med['build']:.3g} s, SVG {med['svg']:.3g} s"
            f" = {(med['build'] + med['svg']) / med['wall']:.0%} of the wall time"})
    report.add(common.markdown(rows, "The demo, end to end (subprocess)", "-"))


def bench_help(report: common.Report, repeats: int, pythonpath=None, **_) -> None:
    env = _env(pythonpath)

    def sub(*cmd):
        return lambda: subprocess.run(list(cmd), stdout=subprocess.DEVNULL, check=True, env=env)

    runs, detail = _timed({
        'python -c "import numpy" (floor)': sub(PYTHON, "-c", "import numpy"),
        "accelcal --help": sub(str(Path(PYTHON).with_name("accelcal")), "--help"),
    }, max(repeats, 9))
    report.add(common.markdown(common.figures(runs, detail,
                                              floor='python -c "import numpy" (floor)'),
                               "Start-up (subprocesses)", "import numpy"))


SECTIONS = {"sinefit": bench_sinefit, "vre": bench_vre, "records": bench_records,
            "response": bench_response, "figures": bench_figures, "demo": bench_demo,
            "help": bench_help}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=[])
    parser.add_argument("--repeats", type=int, default=5, help="interleaved repeats (>= 5)")
    parser.add_argument("--pythonpath", help="source tree for the subprocess sections "
                        "(vre, demo, help), e.g. a patched copy of src/")
    common.add_docs_option(parser)
    args = parser.parse_args()
    report = common.Report("reduce")
    print(common.describe(report.start))
    start = time.perf_counter()
    for name in args.sections or SECTIONS:
        SECTIONS[name](report, args.repeats, pythonpath=args.pythonpath)
    print(f"\n(total {time.perf_counter() - start:.0f} s)")
    report.finish(args.update_docs)


if __name__ == "__main__":
    main()
