"""Noise benchmarks: accelcal against allantools on one series, and the memory of a long stream.

Run from the repository root::

    python benchmarks/noise.py                 # both sections (the memory one takes minutes)
    python benchmarks/noise.py speed --repeats 9
    python benchmarks/noise.py memory --samples 100000000
    python benchmarks/noise.py --update-docs   # also write docs/benchmarks.md (section noise)

``speed``: the overlapping Allan deviation at octave taus of one series of
``--samples`` samples (default 1e7; white noise plus a random walk), each
whole public call timed: ``accelcal.signal.allan.deviations.deviation``
(deviations, noise identification per tau, Greenhall-Riley EDF, chi-square
intervals) and ``allantools.oadev`` (deviations and its simple error bars),
beside the floor of one read of the array (``np.sum``). Each figure is the
median of ``--repeats`` runs (default 7) timed interleaved by
:func:`common.interleaved` (A, B, C, A, B, C, ...), with its ratio to the
floor, the 1-minute load average and the other processes' CPU beside it.
The summary gives the largest relative difference between the two
deviations over their common taus (they must agree to 1e-9) and the speed
ratio allantools / accelcal.

``memory``: a Parquet noise record of ``--samples`` samples (default 1e8)
is written (streamed), then, in a new process, streamed through the
overlapping ADEV with noise identification and intervals
(:func:`accelcal.methods.noise.stream.stream_deviation`); the summary gives
the process's peak resident memory (``resource.getrusage``, ``ru_maxrss``:
it counts the pages of the memmapped phase file that were touched, which
are page cache) and its peak anonymous resident memory (``RssAnon`` of
``/proc/self/status``, sampled every 20 ms: the memory the process itself
holds) beside the samples' size as float64, with the stream's wall time
(one run) and the load average before it.

``kinds``: every deviation kind at octave taus (white FM plus a random walk),
``deviation`` against allantools' function of the same kind, at 1e6 and 1e7
samples (``--samples`` gives one size), medians of ``--repeats`` interleaved
runs beside the floor of one read; the summary gives, per kind and size, the
ratio accelcal / allantools, the largest relative difference of the
deviations and how many of the identified alphas equal allantools'
``autocorr_noise_id`` at the same averaging factor (clipped to the kind's
range as accelcal clips it).

``--update-docs`` writes the tables into ``docs/benchmarks.md`` (sections
``noise`` and ``noise.kinds``).
"""

import common  # noqa: I001  (first: it pins BLAS to one thread before numpy loads)

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

AGREEMENT = 1e-9
"""Largest relative difference allowed between accelcal's and allantools' deviations."""


def _agreement(ours, taus, dev) -> tuple[float, int]:
    """Largest relative difference of the deviations at the common taus, and their count."""
    mine, theirs = np.round(ours.tau, 9), np.round(taus, 9)
    common_taus = np.intersect1d(mine, theirs)
    a = ours.dev[np.isin(mine, common_taus)]
    b = dev[np.isin(theirs, common_taus)]
    return float(np.max(np.abs(a / b - 1))), common_taus.size


def bench_speed(report: common.Report, samples: int, repeats: int, rate: float = 100.0) -> None:
    """accelcal vs allantools, oadev at octave taus of the same series."""
    import allantools

    from accelcal.signal.allan.deviations import deviation

    rng = np.random.default_rng(1)
    y = 1e-4 * rng.standard_normal(samples) + 1e-7 * np.cumsum(rng.standard_normal(samples))
    ours = deviation(y, rate, kind="oadev", taus="octave")
    taus, dev, _, _ = allantools.oadev(y, rate=rate, data_type="freq", taus="octave")
    agree, n_common = _agreement(ours, taus, dev)
    floor, mine, theirs = ("read once (np.sum, floor)", "accelcal deviation(oadev, octave)",
                           "allantools.oadev(octave)")
    detail: dict = {}
    runs = common.interleaved({
        floor: lambda: np.sum(y),
        mine: lambda: deviation(y, rate, kind="oadev", taus="octave"),
        theirs: lambda: allantools.oadev(y, rate=rate, data_type="freq", taus="octave"),
    }, repeats, detail=detail)
    rows = {r.name: r for r in common.figures(runs, detail, floor=floor, notes={
        mine: "deviations, noise identification, EDF, chi-square intervals",
        theirs: "deviations, simple error bars"})}
    report.add(common.markdown(
        list(rows.values()), f"Overlapping ADEV at octave taus, {samples:,} samples "
        f"(median of {repeats})", floor_name="one read"))
    report.add(common.pairs([
        ("octave taus, accelcal / allantools", f"{ours.tau.size} / {len(taus)}"),
        (f"largest relative difference of the deviations over the {n_common} common taus",
         f"{agree:.2g} ({'within' if agree <= AGREEMENT else 'OUTSIDE'} {AGREEMENT:g})"),
        ("allantools / accelcal, median wall times",
         f"{rows[theirs].median_s / rows[mine].median_s:.2f}"),
        ("allantools / accelcal, median CPU times",
         f"{common.median(detail[theirs].cpu) / common.median(detail[mine].cpu):.2f}"),
    ], "Noise speed: summary"))


KINDS = ("oadev", "adev", "mdev", "hdev", "ohdev", "totdev")
"""The kinds compared with allantools (its functions of the same names)."""


def bench_kinds(report: common.Report, sizes, repeats: int, rate: float = 100.0) -> None:
    """accelcal vs allantools for every kind, at each size."""
    import allantools

    from accelcal.signal.allan.deviations import deviation
    from accelcal.signal.allan.identify import alpha_range

    lines = []
    for samples in sizes:
        rng = np.random.default_rng(2)
        y = 1e-4 * rng.standard_normal(samples) + 1e-7 * np.cumsum(rng.standard_normal(samples))
        for kind in KINDS:
            theirs_fn = getattr(allantools, kind)
            ours = deviation(y, rate, kind=kind, taus="octave")
            taus, dev, _, _ = theirs_fn(y, rate=rate, data_type="freq", taus=ours.tau)
            agree, n_common = _agreement(ours, taus, dev)
            low, high = alpha_range(kind)
            dmax = 3 if kind in ("hdev", "ohdev") else 2
            ident = [k for k, s in enumerate(ours.alpha_source) if s == "identified"]
            same = sum(int(ours.alpha[k]) == min(max(allantools.autocorr_noise_id(
                y, int(ours.m[k]), data_type="freq", dmax=dmax)[0], low), high) for k in ident)
            floor, mine, other = "read once", f"accelcal {kind}", f"allantools {kind}"
            detail: dict = {}
            runs = common.interleaved({
                floor: lambda y=y: np.sum(y),
                mine: lambda y=y, kind=kind: deviation(y, rate, kind=kind, taus="octave"),
                other: lambda y=y, f=theirs_fn, t=ours.tau: f(y, rate=rate, data_type="freq",
                                                             taus=t),
            }, repeats, detail=detail)
            rows = {r.name: r for r in common.figures(runs, detail, floor=floor)}
            what = (f"{kind}, {samples:,} samples: accelcal / allantools (median wall); "
                    "deviations' largest relative difference; alphas equal")
            value = (f"{rows[mine].median_s / rows[other].median_s:.2f} "
                     f"({rows[mine].median_s:.3g} s / {rows[other].median_s:.3g} s); "
                     f"{agree:.2g} over {n_common} taus; {same} of {len(ident)}")
            lines.append((what, value))
            print(lines[-1][0].split(":")[0], lines[-1][1], flush=True)
    lines.append(("load before the last run (1 min)",
                  f"{os.getloadavg()[0]:.2f} on {common.cpus()} CPUs"))
    report.add(common.pairs(lines, "Noise speed by kind: deviation() against allantools "
                            f"(median of {repeats} interleaved runs)"))


_CHILD = """
import json, resource, sys, threading, time
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
print(json.dumps({"samples": prov["samples"], "taus": int(dev.tau.size), "seconds": seconds,
                  "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "anon_mib": peak_anon[0] / 1024}))
"""


def bench_memory(report: common.Report, samples: int, rate: float = 1000.0) -> None:
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
        out = common.child_json(_CHILD, path, tmp)
        size = path.stat().st_size / 2**20
    report.add(common.pairs([
        ("samples streamed from Parquet (file size, time to write it)",
         f"{out['samples']:,} ({size:.0f} MiB, {written:.1f} s)"),
        ("octave taus", str(out["taus"])),
        ("peak resident memory (ru_maxrss, with the memmapped phase file's pages)",
         f"{out['peak_mib']:.0f} MiB"),
        ("peak anonymous resident memory (RssAnon: the process's own)",
         f"{out['anon_mib']:.0f} MiB"),
        ("the samples as float64", f"{8 * out['samples'] / 2**20:.0f} MiB"),
        ("wall time of the stream (one run)", f"{out['seconds']:.1f} s"),
        ("load before the run (1 min)", f"{load:.2f} on {common.cpus()} CPUs"),
    ], "Noise memory: oadev of a long record streamed by stream_deviation (fresh subprocess)"))


DEFAULT_SAMPLES = {"speed": 10_000_000, "memory": 100_000_000, "kinds": (1_000_000, 10_000_000)}
"""The sections and the samples of each when ``--samples`` is not given."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sections", nargs="*", choices=[*DEFAULT_SAMPLES, []], default=[])
    parser.add_argument("--samples", type=int, default=None,
                        help="samples of the series (default: 1e7 for speed, 1e8 for memory)")
    parser.add_argument("--repeats", type=int, default=7,
                        help="speed: interleaved repeats (>= 5)")
    common.add_docs_option(parser)
    args = parser.parse_args()
    # "kinds" keeps its own section of the docs (noise.kinds), so that either can be rerun
    reports = {"kinds": common.Report("noise.kinds", "noise.py kinds")}
    report = common.Report("noise")
    print(common.describe(report.start))
    for name in args.sections or DEFAULT_SAMPLES:
        samples = args.samples or DEFAULT_SAMPLES[name]
        if name == "speed":
            bench_speed(report, samples, args.repeats)
        elif name == "kinds":
            bench_kinds(reports["kinds"], (samples,) if args.samples else samples, args.repeats)
        else:
            bench_memory(report, samples)
    for part in (report, *reports.values()):
        if part.parts:
            part.finish(args.update_docs)


if __name__ == "__main__":
    main()
