"""accelcal benchmarks: ratios measured side by side in one run.

Run from the repository root::

    python benchmarks/run.py            # everything
    python benchmarks/run.py sinefit    # one section

Absolute times on a shared machine mean little; each section times its
candidates interleaved (A, B, C, A, B, C, ...) and reports the best of the
repeats and their ratios.
"""

import argparse
import time

import numpy as np


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


SECTIONS = {"sinefit": bench_sinefit}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=list(SECTIONS))
    args = parser.parse_args()
    for name in args.sections or SECTIONS:
        SECTIONS[name]()


if __name__ == "__main__":
    main()
