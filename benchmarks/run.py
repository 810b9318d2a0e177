"""accelcal benchmarks: ratios measured side by side in one run.

Run from the repository root::

    python benchmarks/run.py                  # everything (the memory section takes minutes)
    python benchmarks/run.py sinefit study    # some sections
    python benchmarks/run.py dask --dask-trials 1000000

Sections: ``sinefit`` (three-parameter sine fit), ``study`` (indexing-head
Monte Carlo throughput against the random-number floor and a per-trial
implementation), ``dask`` (1 and 2 Dask workers on one study: speed-up and
identity of results), ``memory`` (peak resident memory of a long study, in
a subprocess).

Absolute times on a shared machine mean little; each section times its
candidates interleaved (A, B, C, A, B, C, ...) and reports the best of the
repeats and their ratios. BLAS runs single-threaded (as in a Dask worker),
so every ratio compares one core with one core.
"""

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads its BLAS

import numpy as np  # noqa: E402


def best_times(candidates: dict, repeat: int = 5) -> dict[str, float]:
    """Best wall time of each candidate, timed interleaved to share the machine's noise."""
    best = dict.fromkeys(candidates, float("inf"))
    for _ in range(repeat):
        for name, fn in candidates.items():
            start = time.perf_counter()
            fn()
            best[name] = min(best[name], time.perf_counter() - start)
    return best


def table(title: str, rows: list[tuple]) -> None:
    print(f"\n{title}")
    width = max(len(r[0]) for r in rows)
    for r in rows:
        print(f"  {r[0]:<{width}}  " + "  ".join(str(c) for c in r[1:]))


def bench_sinefit(records: int = 64, samples: int = 100_000, curve_fit_records: int = 4) -> None:
    """Three-parameter sine fit on long shaker records vs one read and vs curve_fit."""
    from scipy.optimize import curve_fit

    from accelcal.signal.sinefit import HarmonicFit

    fs, f = 20_000.0, 137.0
    rng = np.random.default_rng(1)
    t = np.arange(samples) / fs
    amp = rng.uniform(0.5, 2.0, (records, 1))
    phase = rng.uniform(0, 2 * np.pi, (records, 1))
    y = 0.1 + amp * np.sin(2 * np.pi * f * t + phase) + rng.normal(0, 1e-3, (records, samples))
    fit = HarmonicFit(samples, fs, f)

    def model(tt, c, a, b):
        return c + a * np.cos(2 * np.pi * f * tt) + b * np.sin(2 * np.pi * f * tt)

    def by_curve_fit():
        return np.array([curve_fit(model, t, y[i], p0=(0.0, 0.0, 1.0))[0]
                         for i in range(curve_fit_records)])

    times = best_times({
        "read once (sum)": lambda: y.sum(axis=-1),
        "accelcal sine_fit3": lambda: fit(y),
        "curve_fit": by_curve_fit,
    }, repeat=3)
    ours = fit(y).parameters[:curve_fit_records]
    theirs = by_curve_fit()
    agree = float(np.max(np.abs(ours - theirs) / np.max(np.abs(theirs), axis=1, keepdims=True)))
    per_sample = {k: v / (curve_fit_records if k == "curve_fit" else records) / samples
                  for k, v in times.items()}
    rate = {k: 1.0 / v for k, v in per_sample.items()}
    ref = per_sample["accelcal sine_fit3"]
    table(
        f"Sine fit: {records} records x {samples} samples (curve_fit on {curve_fit_records})",
        [("candidate", "samples/s", "time per sample / accelcal's")]
        + [(k, f"{rate[k]:.3g}", f"{per_sample[k] / ref:.3g}") for k in per_sample]
        + [("agreement with curve_fit (max rel.)", f"{agree:.2g}", "")],
    )


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


def bench_study(trials: int = 2**18, naive_trials: int = 200, **_) -> None:
    """Study throughput against drawing the same random numbers and a per-trial loop."""
    sys.path.insert(0, str(Path(__file__).parent))
    from accelcal.methods.dividing_head import (
        STUDY_BLOCK,
        SUB_BLOCK,
        HeadStudy,
        run_study,
    )
    from accelcal.montecarlo import block_generator
    from naive_study import naive_study

    rig, seed = study_rig(), 1
    study = HeadStudy(rig, *_all_methods(rig))
    blocks = [(b, min(STUDY_BLOCK, trials - b * STUDY_BLOCK))
              for b in range(-(-trials // STUDY_BLOCK))]

    def floor():
        for b, n in blocks:
            rng, work = block_generator(seed, b), {}
            for start in range(0, n, SUB_BLOCK):
                study.draw(rng, min(SUB_BLOCK, n - start), work)

    def simulate_only():
        for b, n in blocks:
            study(block_generator(seed, b), n)

    times = best_times({
        "draw the same random numbers (floor)": floor,
        "study: simulate and reduce": simulate_only,
        "study via accelcal.montecarlo.run": lambda: run_study(rig, trials, seed),
        "per-trial public reductions": lambda: naive_study(rig, naive_trials, seed,
                                                           study.methods),
    }, repeat=3)
    per_trial = {k: v / (naive_trials if k.startswith("per-trial") else trials)
                 for k, v in times.items()}
    floor_t = per_trial["draw the same random numbers (floor)"]
    ours = per_trial["study via accelcal.montecarlo.run"]
    naive_rms, naive_sd = naive_study(rig, naive_trials, seed, study.methods)
    vec = run_study(rig, naive_trials, seed)
    agree = max(float(np.max(np.abs(naive_rms / vec.rms_error - 1))),
                float(np.max(np.abs(naive_sd / vec.mean_formal_sd - 1))))
    table(
        f"Indexing-head study: 24 positions x 4 sensors, methods {', '.join(study.methods)}; "
        f"{trials} trials (per-trial loop on {naive_trials})",
        [("candidate", "trials/s", "us/trial", "time / floor", "time / study's")]
        + [(k, f"{1 / v:.3g}", f"{v * 1e6:.3g}", f"{v / floor_t:.3g}", f"{v / ours:.3g}")
           for k, v in per_trial.items()]
        + [("targets: study <= 2x floor; per-trial >= 50x study", "", "",
            f"study {ours / floor_t:.2f}x",
            f"per-trial {per_trial['per-trial public reductions'] / ours:.0f}x"),
           ("same trials, per-trial vs vectorised (max rel. diff.)", f"{agree:.2g}", "", "", "")],
    )


def _all_methods(rig):
    from accelcal.methods.dividing_head.study import _applicable

    return _applicable(rig)[0], 0.0


def bench_dask(trials: int = 10**7, repeat: int = 2, **_) -> None:
    """One study on a local Dask cluster of 1 and of 2 worker processes (cluster start included)."""
    from accelcal.methods.dividing_head import run_study

    rig, results, best = study_rig(), {}, {}
    for r in range(repeat):
        for workers in (1, 2):
            print(f"  dask: {trials} trials on {workers} worker(s), run {r + 1}/{repeat} ...",
                  flush=True)
            start = time.perf_counter()
            results[workers] = run_study(rig, trials, 7, workers=workers)
            elapsed = time.perf_counter() - start
            best[workers] = min(best.get(workers, float("inf")), elapsed)
    same = all(np.array_equal(getattr(results[1], f), getattr(results[2], f))
               for f in ("rms_error", "mean_formal_sd"))
    table(
        f"Dask local cluster: {trials} trials, best of {repeat} (cluster start-up included)",
        [("workers", "time (s)", "trials/s", "speed-up")]
        + [(str(w), f"{best[w]:.3g}", f"{trials / best[w]:.3g}", f"{best[1] / best[w]:.2f}")
           for w in (1, 2)]
        + [("target: 2 workers >= 1.6x one; results bit-identical", "", "", f"identical: {same}")],
    )


_MEMORY_CHILD = """
import resource, sys, time
sys.path.insert(0, {bench!r})
from run import study_rig
from accelcal.methods.dividing_head import run_study
trials, step, last = {trials}, max(1, {trials} // 20), [0]
start = time.perf_counter()

def progress(done, total):
    if done - last[0] >= step or done == total:
        last[0] = done
        rate = done / (time.perf_counter() - start)
        print(f"  memory: {{done}}/{{total}} trials, {{rate:.3g}} trials/s, "
              f"peak {{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}} MiB",
              file=sys.stderr, flush=True)

res = run_study(study_rig(), trials, 3, progress=progress)
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.perf_counter() - start)
"""


def bench_memory(trials: int = 10**8, **_) -> None:
    """Peak resident memory (ru_maxrss) of one in-process study, in a fresh subprocess."""
    code = _MEMORY_CHILD.format(bench=str(Path(__file__).parent), trials=trials)
    print(f"  memory: {trials} trials in a subprocess (progress every 5 %) ...", flush=True)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=False,
                         stdout=subprocess.PIPE, text=True).stdout.split()
    peak_mib, elapsed = int(out[0]) / 1024, float(out[1])
    table(
        f"Peak memory of a {trials}-trial study (in-process, one core)",
        [("quantity", "value"),
         ("peak resident memory (ru_maxrss)", f"{peak_mib:.0f} MiB"),
         ("target: under 1 GiB", "met" if peak_mib < 1024 else "MISSED"),
         ("time", f"{elapsed:.0f} s ({trials / elapsed:.3g} trials/s)")],
    )


SECTIONS = {"sinefit": bench_sinefit, "study": bench_study, "dask": bench_dask,
            "memory": bench_memory}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=[])
    parser.add_argument("--dask-trials", type=int, default=10**7,
                        help="trials of the dask section's study")
    parser.add_argument("--memory-trials", type=int, default=10**8,
                        help="trials of the memory section's study")
    args = parser.parse_args()
    options = {"dask": {"trials": args.dask_trials}, "memory": {"trials": args.memory_trials}}
    for name in args.sections or SECTIONS:
        SECTIONS[name](**options.get(name, {}))


if __name__ == "__main__":
    main()
