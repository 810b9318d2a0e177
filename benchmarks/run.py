"""accelcal benchmarks: ratios measured side by side in one run (harness: common.py).

Run from the repository root::

    python benchmarks/run.py                        # every section (about 8 minutes)
    python benchmarks/run.py study exact            # some sections
    python benchmarks/run.py dask --dask-trials 1000000
    python benchmarks/run.py --update-docs          # also write docs/benchmarks.md

Sections:

- ``sinefit``: the three-parameter sine fit on long records against one
  read of the array and against ``scipy.optimize.curve_fit``;
- ``study``: the indexing-head study of 1e6 trials, whole public call
  (``run_study``: set-up, simulation, reduction, statistics), against the
  bare random-number floor (the uniform ``(N, 24)`` head errors, normal
  ``(N, 96)`` noise and normal ``(N, 2)`` first-harmonic errors drawn with
  numpy's default generator in the study's seed blocks and sub-blocks, into
  preallocated arrays: nothing else) and
  against ``naive_study.py`` (the same trials reduced one at a time by the
  public reductions), per trial;
- ``exact``: ``exact_study`` (``--exact``) against a 1e5-trial Monte Carlo
  study, whole calls, and how far that study is from the exact values;
- ``dask``: the 1e7-trial study on a local Dask cluster of 1 and of 2 worker
  processes (cluster start included): speed-up and identity of results;
  the verdict is given only when the machine was idle before the section
  started (1-minute load average per core at most 0.5);
- ``memory``: peak resident memory (``ru_maxrss``) of a 1e6- and a
  1e7-trial study, each in a fresh subprocess.

Every figure is the median of at least 5 runs timed interleaved (A, B, C,
A, B, C, ...), with the median 1-minute load average before its runs beside
it; a figure taken with more than 0.5 load per core is flagged "under load".
CPU-time ratios are printed too: other processes inflate them less than
wall-time ratios. BLAS runs single-threaded (as in a Dask worker).
"""

import argparse
import os
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS (common.py does the same)
sys.path.insert(0, str(Path(__file__).parent))

import numpy as np  # noqa: E402

import common  # noqa: E402


def study_rig():
    """The benchmark's indexing head: 24 positions, 4 sensors (Dong2014 Table 1)."""
    from accelcal.rigs.dividing_head import (
        DONG2014_FIRST_HARMONIC,
        DONG2014_NOISE_V,
        AngleErrorProfile,
        DividingHeadRig,
        dong2014_models,
    )
    from accelcal.units import ARCSEC

    return DividingHeadRig.uniform(
        24, dong2014_models(4), angle_error=AngleErrorProfile.uniform(2 * ARCSEC),
        first_harmonic=DONG2014_FIRST_HARMONIC, noise=DONG2014_NOISE_V,
    )


def bench_sinefit(report, records: int = 64, samples: int = 100_000,
                  curve_fit_records: int = 4, **_) -> None:
    """Three-parameter sine fit on long shaker records vs one read and vs curve_fit."""
    from scipy.optimize import curve_fit

    from accelcal.signal.sinefit import sine_fit3

    fs, f = 20_000.0, 137.0
    rng = np.random.default_rng(1)
    t = np.arange(samples) / fs
    amp = rng.uniform(0.5, 2.0, (records, 1))
    phase = rng.uniform(0, 2 * np.pi, (records, 1))
    y = 0.1 + amp * np.sin(2 * np.pi * f * t + phase) + rng.normal(0, 1e-3, (records, samples))

    def model(tt, c, a, b):
        return c + a * np.cos(2 * np.pi * f * tt) + b * np.sin(2 * np.pi * f * tt)

    def by_curve_fit():
        return [curve_fit(model, t, y[i], p0=(0.0, 0.0, 1.0))[0]
                for i in range(curve_fit_records)]

    detail = {}
    runs = common.interleaved({
        "read once (sum)": lambda: y.sum(axis=-1),
        "accelcal sine_fit3 (whole call)": lambda: sine_fit3(y, fs, f),
        f"curve_fit ({curve_fit_records} records)": by_curve_fit,
    }, detail=detail)
    per = {f"curve_fit ({curve_fit_records} records)": curve_fit_records / records}
    report.add(common.markdown(
        common.figures(runs, detail, floor="read once (sum)", per=per),
        f"Sine fit: {records} records x {samples} samples (curve_fit timed on "
        f"{curve_fit_records}, ratios per record)", floor_name="one read"))


def _floor(trials: int, seed: int, half_width: float):
    """The bare random numbers of the study, in its seed blocks and sub-blocks.

    Per trial, as the study draws them: 24 uniform head errors, 96 normal
    noises (4 sensors x 24 positions) and 2 normal first-harmonic errors.
    """
    from accelcal.methods.dividing_head import STUDY_BLOCK, SUB_BLOCK
    from accelcal.montecarlo import block_generator

    def floor():
        u, z, h1 = np.empty((SUB_BLOCK, 24)), np.empty((SUB_BLOCK, 96)), np.empty((SUB_BLOCK, 2))
        for b in range(-(-trials // STUDY_BLOCK)):
            n, rng = min(STUDY_BLOCK, trials - b * STUDY_BLOCK), block_generator(seed, b)
            for start in range(0, n, SUB_BLOCK):
                t = min(SUB_BLOCK, n - start)
                rng.random(out=u[:t])
                rng.standard_normal(out=z[:t])
                rng.standard_normal(out=h1[:t])
    return floor


def bench_study(report, trials: int = 10**6, naive_trials: int = 200, **_) -> None:
    """Study per trial against the bare random-number floor and a per-trial loop."""
    from accelcal.methods.dividing_head import HeadStudy, run_study
    from accelcal.methods.dividing_head.study import _applicable
    from naive_study import naive_study

    rig, seed = study_rig(), 1
    methods = _applicable(rig)[0]
    floor, study, naive = ("bare random numbers (floor)", "accelcal run_study (whole call)",
                           f"per-trial public reductions ({naive_trials} trials)")
    detail = {}
    runs = common.interleaved({
        floor: _floor(trials, seed, rig.angle_error.half_width),
        study: lambda: run_study(rig, trials, seed),
        naive: lambda: naive_study(rig, naive_trials, seed, methods),
    }, detail=detail)
    per = {floor: trials, study: trials, naive: naive_trials}
    rows = common.figures(runs, detail, floor=floor, per=per)
    naive_rms, naive_sd = naive_study(rig, naive_trials, seed, HeadStudy(rig, methods, 0).methods)
    vec = run_study(rig, naive_trials, seed)
    agree = max(float(np.max(np.abs(naive_rms / vec.rms_error - 1))),
                float(np.max(np.abs(naive_sd / vec.mean_formal_sd - 1))))
    us = {r.name: r.median_s / per[r.name] * 1e6 for r in rows}
    report.add(common.markdown(
        rows, f"Indexing-head study, {trials} trials: 24 positions x 4 sensors, methods "
              f"{', '.join(methods)}; ratios per trial"))
    report.add(common.pairs([
        ("floor, us per trial", f"{us[floor]:.3g}"),
        ("study, us per trial", f"{us[study]:.3g}"),
        ("per-trial loop, us per trial", f"{us[naive]:.3g}"),
        ("study / floor (target <= 2)", f"{rows[1].ratio:.2f} (CPU time {rows[1].cpu_ratio:.2f})"),
        ("per-trial loop / study", f"{us[naive] / us[study]:.0f}"),
        ("same trials, per-trial vs vectorised (max rel. diff.)", f"{agree:.2g}"),
    ], "Study: summary"))


def bench_exact(report, trials: int = 10**5, **_) -> None:
    """``exact_study`` against a Monte Carlo study, whole calls."""
    from accelcal.methods.dividing_head import run_study
    from accelcal.methods.dividing_head.exact import exact_study

    rig = study_rig()
    exact, mc = "exact_study (--exact)", f"run_study, {trials} trials"
    detail = {}
    runs = common.interleaved({mc: lambda: run_study(rig, trials, 3, h1_sd=5e-7),
                               exact: lambda: exact_study(rig, h1_sd=5e-7)}, detail=detail)
    report.add(common.markdown(common.figures(runs, detail, floor=mc),
                               "Exact study against Monte Carlo (h1_sd 5e-7)",
                               floor_name="Monte Carlo"))
    ex, sim = exact_study(rig, h1_sd=5e-7), run_study(rig, trials, 3, h1_sd=5e-7)
    report.add(common.pairs([
        ("RMS errors: largest relative difference, MC against exact",
         f"{np.max(np.abs(sim.rms_error / ex.rms_error - 1)):.2g}"),
        ("mean formal SDs: largest relative difference, MC against exact",
         f"{np.max(np.abs(sim.mean_formal_sd / ex.mean_formal_sd - 1)):.2g}"),
        ("expected sampling error of an RMS from this many trials (relative)",
         f"about {1 / np.sqrt(2 * trials):.1g} (more where a bias dominates)"),
    ], f"Exact study against {trials} Monte Carlo trials"))


def bench_dask(report, trials: int = 10**7, repeats: int = 5, **_) -> None:
    """One study on a local Dask cluster of 1 and of 2 worker processes (start-up included)."""
    from accelcal.methods.dividing_head import run_study

    load0 = os.getloadavg()[0]
    idle = not common.busy(load0)
    rig, results = study_rig(), {}

    def on(workers):
        def run():
            print(f"  dask: {trials} trials on {workers} worker(s) ...", flush=True)
            results[workers] = run_study(rig, trials, 7, workers=workers)
        return run

    detail = {}
    runs = common.interleaved({"1 worker": on(1), "2 workers": on(2)}, repeats=repeats,
                              detail=detail)
    rows = common.figures(runs, detail, floor="1 worker", cpu_ratios=False)  # work in workers
    same = all(np.array_equal(getattr(results[1], f), getattr(results[2], f))
               for f in ("rms_error", "mean_formal_sd"))
    speedup = 1 / rows[1].ratio
    idle = idle and not any(r.flagged for r in rows)  # nor crowded during the runs
    if idle:
        verdict = f"{'met' if speedup >= 1.6 and same else 'MISSED'} (speed-up {speedup:.2f})"
    else:
        verdict = (f"not judged: the machine was busy (load {load0:.2f} on {common.cpus()} "
                   "CPUs before the section, or other processes' CPU during the runs)")
    report.add(common.markdown(rows, f"Dask local cluster: {trials} trials (cluster start-up "
                                     "included)", floor_name="1 worker"))
    report.add(common.pairs([
        ("load before the section (1 min)", f"{load0:.2f} on {common.cpus()} CPUs"),
        ("speed-up of 2 workers (median wall times)", f"{speedup:.2f}"),
        ("results of 1 and 2 workers bit-identical", str(same)),
        ("target: 2 workers >= 1.6x one on an idle machine", verdict),
    ], "Dask: summary"))


_MEMORY_CHILD = """
import json, resource, sys, time
sys.path.insert(0, {bench!r})
from run import study_rig
from accelcal.methods.dividing_head import run_study
start = time.perf_counter()
run_study(study_rig(), {trials}, 3)
print(json.dumps({{"maxrss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
                  "seconds": time.perf_counter() - start}}))
"""


def bench_memory(report, trials: int = 10**7, **_) -> None:
    """Peak resident memory (ru_maxrss) of in-process studies, each in a fresh subprocess."""
    out = {}
    for n in (trials // 10, trials):
        code = _MEMORY_CHILD.format(bench=str(Path(__file__).parent), trials=n)
        print(f"  memory: {n} trials in a subprocess ...", flush=True)
        load = os.getloadavg()[0]
        child = common.child_json(code)
        out[n] = (child["maxrss_kib"] / 1024, child["seconds"], load)
    small, large = out[trials // 10], out[trials]
    report.add(common.pairs([
        (f"peak resident memory, {trials // 10} trials",
         f"{small[0]:.0f} MiB ({small[1]:.1f} s, load {small[2]:.2f})"),
        (f"peak resident memory, {trials} trials",
         f"{large[0]:.0f} MiB ({large[1]:.1f} s, load {large[2]:.2f})"),
        ("ratio (flat: ~1)", f"{large[0] / small[0]:.2f}"),
    ], "Peak memory of a study (in-process, one core, fresh subprocess each)"))


SECTIONS = {"sinefit": bench_sinefit, "study": bench_study, "exact": bench_exact,
            "dask": bench_dask, "memory": bench_memory}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=[])
    parser.add_argument("--study-trials", type=int, default=10**6)
    parser.add_argument("--dask-trials", type=int, default=10**7,
                        help="trials of the dask section's study")
    parser.add_argument("--memory-trials", type=int, default=10**7,
                        help="trials of the memory section's larger study")
    common.add_docs_option(parser)
    args = parser.parse_args()
    options = {"study": {"trials": args.study_trials}, "dask": {"trials": args.dask_trials},
               "memory": {"trials": args.memory_trials}}
    start = time.perf_counter()
    for name in args.sections or SECTIONS:
        # One docs section per benchmark section (<!-- bench:run.NAME -->): running some
        # sections replaces only theirs.
        report = common.Report(f"run.{name}", script=f"run.py {name}")
        t0 = time.perf_counter()
        SECTIONS[name](report, **options.get(name, {}))
        report.add(f"Section wall time {time.perf_counter() - t0:.0f} s.")
        report.finish(args.update_docs)
    print(f"\ntotal wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
