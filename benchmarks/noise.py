"""Noise benchmarks: accelcal against allantools on one series, and the memory of a long stream.

Run from the repository root::

    python benchmarks/noise.py                 # both sections (the memory one takes minutes)
    python benchmarks/noise.py speed           # time only
    python benchmarks/noise.py memory --samples 100000000

``speed``: the overlapping Allan deviation at octave taus of one 1e7-sample
series (white noise plus a random walk), each whole public call timed:
``accelcal.signal.allan.deviations.deviation`` (deviations, noise
identification per tau, Greenhall-Riley EDF, chi-square intervals) and
``allantools.oadev`` (deviations and its simple error bars), beside the
floor of one read of the array (``np.sum``). Medians of 7 repeats,
interleaved (A, B, C, A, B, C ...); the 1-minute load average of the
machine is printed beside each figure. The deviations must agree to 1e-9.

``memory``: a Parquet noise record of ``--samples`` samples is written
(streamed), then, in a new process, streamed through the overlapping ADEV
with noise identification and intervals (:func:`accelcal.methods.noise.stream.stream_deviation`);
the process's peak resident memory (``resource.getrusage``, ``ru_maxrss``:
it counts the pages of the memmapped phase file that were touched, which
are page cache) and its peak anonymous resident memory (``RssAnon`` of
``/proc/self/status``, sampled every 20 ms: the memory the process itself
holds) are printed beside the record's size as float64.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402


def median_times(candidates: dict, repeat: int = 7) -> dict[str, tuple[float, float]]:
    """Median wall time and mean load average of each candidate, timed interleaved."""
    times = {k: [] for k in candidates}
    loads = {k: [] for k in candidates}
    for _ in range(repeat):
        for name, fn in candidates.items():
            loads[name].append(os.getloadavg()[0])
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    return {k: (statistics.median(times[k]), float(np.mean(loads[k]))) for k in candidates}


def bench_speed(samples: int = 10_000_000, rate: float = 100.0) -> None:
    """accelcal vs allantools, oadev at octave taus of the same series."""
    import allantools

    from accelcal.signal.allan.deviations import deviation

    rng = np.random.default_rng(1)
    y = 1e-4 * rng.standard_normal(samples) + 1e-7 * np.cumsum(rng.standard_normal(samples))
    ours = deviation(y, rate, kind="oadev", taus="octave")
    taus, dev, _, _ = allantools.oadev(y, rate=rate, data_type="freq", taus="octave")
    common = np.intersect1d(np.round(ours.tau, 9), np.round(taus, 9))
    a = ours.dev[np.isin(np.round(ours.tau, 9), common)]
    b = dev[np.isin(np.round(taus, 9), common)]
    agree = float(np.max(np.abs(a / b - 1)))
    res = median_times({
        "read once (np.sum)": lambda: np.sum(y),
        "accelcal deviation(oadev, octave)": lambda: deviation(y, rate, kind="oadev",
                                                               taus="octave"),
        "allantools.oadev(octave)": lambda: allantools.oadev(y, rate=rate, data_type="freq",
                                                             taus="octave"),
    })
    print(f"\nspeed: {samples:.0e} samples, {ours.tau.size} octave taus (allantools "
          f"{len(taus)}), max relative difference {agree:.1e} over {common.size} common taus")
    floor = res["read once (np.sum)"][0]
    for name, (t, load) in res.items():
        print(f"  {name:<36} {t:9.3f} s  {t / floor:8.1f} x floor   load {load:.2f}")
    ratio = res["allantools.oadev(octave)"][0] / res["accelcal deviation(oadev, octave)"][0]
    print(f"  allantools / accelcal: {ratio:.2f}")


_CHILD = """
import resource, sys, threading, time
from accelcal.methods.noise.stream import stream_deviation

peak_anon = [0]
done = threading.Event()

def watch():  # the anonymous resident memory (RssAnon), sampled every 20 ms
    while not done.is_set():
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("RssAnon:"):
                    peak_anon[0] = max(peak_anon[0], int(line.split()[1]))
        time.sleep(0.02)

threading.Thread(target=watch, daemon=True).start()
start = time.perf_counter()
dev, _, prov = stream_deviation(sys.argv[1], tmpdir=sys.argv[2])
seconds = time.perf_counter() - start
done.set()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(f"{prov['samples']} {dev.tau.size} {seconds:.1f} {peak:.0f} {peak_anon[0] / 1024:.0f}")
"""


def bench_memory(samples: int = 100_000_000, rate: float = 1000.0) -> None:
    """Peak resident memory of streaming a long Parquet record (in a child process)."""
    from accelcal.io.formats.noise import write_blocks
    from accelcal.rigs.noise import simulate_blocks

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.parquet"
        start = time.perf_counter()
        write_blocks(path, simulate_blocks(N=2e-5, K=1e-7, rate=rate, duration=samples / rate,
                                           seed=1), rate=rate, unit="g")
        written = time.perf_counter() - start
        load = os.getloadavg()[0]
        out = subprocess.run([sys.executable, "-c", _CHILD, str(path), tmp], check=True,
                             capture_output=True, text=True).stdout.split()
        n, taus, seconds = int(out[0]), int(out[1]), float(out[2])
        peak, anon = float(out[3]), float(out[4])
        print(f"\nmemory: {n:.2e} samples streamed from Parquet ({path.stat().st_size / 2**20:.0f}"
              f" MiB file, written in {written:.0f} s), oadev at {taus} octave taus")
        print(f"  peak resident memory {peak:.0f} MiB, of which anonymous (the process's own) "
              f"{anon:.0f} MiB; the rest is the memmapped phase file's pages (page cache); "
              f"the samples as float64: {8 * n / 2**20:.0f} MiB   time {seconds:.0f} s   "
              f"load {load:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", default=["speed", "memory"])
    parser.add_argument("--samples", type=int, default=100_000_000, help="memory: samples")
    args = parser.parse_args()
    if "speed" in args.sections:
        bench_speed()
    if "memory" in args.sections:
        bench_memory(args.samples)


if __name__ == "__main__":
    main()
