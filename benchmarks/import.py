"""Import: a DAQ's CSV made into a Parquet record, against pyarrow reading the same CSV.

Run from the repository root::

    python benchmarks/import.py                 # 2,000,000 rows x (t + 4 channels)
    python benchmarks/import.py speed --rows 500000 --repeats 7
    python benchmarks/import.py --update-docs   # also write docs/benchmarks.md (section import)
    python benchmarks/import.py detect --update-docs   # triad detect (section import.detect)

A CSV recording of ``--rows`` rows (a time column in ms and four channels in
g, written once by pyarrow) is, in the section ``speed``,

- ``pyarrow.csv.read_csv``: parsed whole by Arrow (the floor: no checks, the
  table held whole);
- ``iter_blocks``: streamed through :func:`accelcal.io.recordings.iter_blocks`
  (the same Arrow parser in blocks of ``--block-rows`` rows, plus the
  checks: finite values, increasing time);
- ``read_recording``: the same, held whole;
- ``import -> parquet``: :func:`accelcal.io.recordings.convert.import_recording`
  to a noise record in blocks of ``--block-rows`` rows (streamed, gap check,
  SHA-256 of the source, Parquet row groups, the record streamed back to
  validate it).

The same section then writes, for each of ``--tdms-rows`` sizes (default 2
and 8 million rows), the four channels to a TDMS file (npTDMS,
segments of 65,536 rows, ``wf_increment`` 1 ms, no time column) and times,
interleaved, ``nptdms.TdmsFile.read`` of the four channels (the floor: the
file read whole into arrays, no checks); the parts of the least an import
that states the source's digest does, each alone: the file's SHA-256 and a
Parquet write of the arrays (read once beforehand) with the record's
options, in the same blocks; the three in one run; ``iter_blocks`` of it
and ``import -> parquet`` of it, in the same blocks. The summary gives the
import against the read (the target: at most 3x) and the parts against
the read, so that a floor above the target shows as such, and says which.
The read whole costs more per row as the file grows (it allocates every
channel at once), the streamed import does not: hence two sizes.

Each figure is the median of ``--repeats`` runs (default 5; ``--repeat`` is
the same option) timed interleaved by :func:`common.interleaved` (A, B, C,
D, A, ...), with its ratio to the floor, its rows per second, the 1-minute
load average and the other processes' CPU beside it.

The section ``memory`` runs ``import -> parquet`` of that CSV and of ones of
4 x and 8 x ``--rows`` rows, each once in a fresh subprocess, and gives each
process's peak resident memory (``ru_maxrss`` of the child from ``os.wait4``
in a small launcher, see :data:`_MEASURE`) and wall time, and the ratios of
the peaks. The import holds a block at a time (and reads the first 2^20 rows
to tell the rate from the time column); Arrow's streaming CSV reader reads
ahead of it and its memory pool grows until that read-ahead is full, which a
CSV of 2 million rows does not reach: so the peaks are compared at 8 and 16
million rows (with the defaults), where they should match.

The section ``detect`` (its own section of the docs, ``import.detect``)
writes a triad recording to Parquet (a time column and three channels at
1 kHz, six positions held 60 s each, turning 2 s between them, row groups
of 2^20 rows) of each of ``--detect-rows`` sizes (default 1e7 and 4e7
rows) and runs, interleaved, each in a fresh process:

- ``pyarrow.parquet.read_table``: the file read whole (the floor);
- ``accelcal triad detect``: the command, streamed, without ``--plot``.

It gives each one's median wall time, its ratio to the floor, the child
processes' CPU time and their peak resident memory (``ru_maxrss`` of the
child, from ``os.wait4``); the summary states the ratios and the peaks
against the targets (at most 2x the read, under 300 MiB at any length).

``--update-docs`` writes the tables into ``docs/benchmarks.md`` (sections
``import`` and, for ``detect``, ``import.detect``).
"""

import common  # noqa: I001  (first: it pins BLAS to one thread before numpy loads)

import argparse
import dataclasses
import functools
import os
import tempfile
from pathlib import Path

import numpy as np

OPTIONS = {"columns": ("a0", "a1", "a2", "a3"), "time": "t_ms", "time_unit": "ms", "unit": "g"}
"""How the CSV is read (:class:`accelcal.io.recordings.InputOptions`)."""
CHANNELS = {f"c{k}": f"a{k}" for k in range(4)}
"""The noise record's columns -> the CSV's."""
DAY_ROWS = 86_400_000
"""Rows of a 24 h recording at 1 kHz, for the summary's extrapolation."""


def write_csv(path: Path, rows: int) -> None:
    import pyarrow as pa
    from pyarrow import csv

    rng = np.random.default_rng(0)
    table = pa.table({"t_ms": np.arange(rows, dtype=float),
                      **{f"a{k}": rng.normal(0.0, 1e-3, rows) + (k == 2) for k in range(4)}})
    csv.write_csv(table, path)


def bench_speed(report: common.Report, src: Path, rows: int, block_rows: int,
                repeats: int) -> None:
    """The CSV parsed by pyarrow, streamed, read whole and imported, interleaved."""
    from pyarrow import csv

    from accelcal.io.recordings import InputOptions, iter_blocks, read_recording
    from accelcal.io.recordings.convert import import_recording

    opts = InputOptions(**OPTIONS)
    out = src.with_name("rec.parquet")

    def streamed():
        for _ in iter_blocks(src, opts, rows=block_rows):
            pass

    floor, imported = "pyarrow.csv.read_csv (floor)", "import -> parquet"
    detail: dict = {}
    runs = common.interleaved({
        floor: lambda: csv.read_csv(src),
        "iter_blocks": streamed,
        "read_recording": lambda: read_recording(src, opts),
        imported: lambda: import_recording(src, opts, kind="noise", channels=CHANNELS,
                                           out=out, rows=block_rows),
    }, repeats, detail=detail)
    notes = {name: f"{rows / common.median(t) / 1e6:.3g} M rows/s" for name, t in runs.items()}
    by_name = {r.name: r for r in common.figures(runs, detail, floor=floor, notes=notes)}
    size = src.stat().st_size / 2**20
    report.add(common.markdown(
        list(by_name.values()), f"A CSV of {rows:,} rows x 5 columns ({size:.0f} MiB), blocks of "
        f"{block_rows:,} rows (median of {repeats})", floor_name="pyarrow"))
    seconds = common.median(runs[imported])
    report.add(common.pairs([
        ("import -> parquet / pyarrow.csv.read_csv, median wall times",
         f"{by_name[imported].ratio:.2f}"),
        ("import -> parquet, rows per second", f"{rows / seconds / 1e6:.3g} M"),
        ("a 24 h, 1 kHz recording (86.4 M rows) at that speed (extrapolated)",
         f"{DAY_ROWS / rows * seconds / 60:.2g} min"),
    ], "Import speed: summary"))


TDMS_SEGMENT = 1 << 16
"""Rows per segment of the benchmark's TDMS file (a DAQ writes one segment per buffer)."""


def write_tdms(path: Path, rows: int) -> None:
    """The CSV's four channels (no time column: ``wf_increment`` 1 ms) in a TDMS file."""
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    rng = np.random.default_rng(0)
    with TdmsWriter(path) as writer:
        for a in range(0, rows, TDMS_SEGMENT):
            n = min(TDMS_SEGMENT, rows - a)
            objs = [RootObject({"title": "benchmark"}), GroupObject("DAQ", {})] if not a else []
            for k in range(4):
                props = {"wf_increment": 1e-3, "unit_string": "g"} if not a else {}
                objs.append(ChannelObject("DAQ", f"a{k}", rng.normal(0.0, 1e-3, n) + (k == 2),
                                          properties=props))
            writer.write_segment(objs)


def bench_tdms(report: common.Report, src: Path, rows: int, block_rows: int,
               repeats: int) -> None:
    """A TDMS file read by npTDMS, its parts, streamed and imported, interleaved."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    from nptdms import TdmsFile

    from accelcal.io.recordings import InputOptions, iter_blocks
    from accelcal.io.recordings.convert import import_recording
    from accelcal.io.recordings.read import sha256
    from accelcal.io.records import parquet_options

    opts = InputOptions(input_format="tdms")
    channels = {f"c{k}": f"DAQ/a{k}" for k in range(4)}
    out = src.with_name("tdms-rec.parquet")
    written = src.with_name("tdms-arrays.parquet")

    def read():
        tdms = TdmsFile.read(src)
        return [tdms["DAQ"][f"a{k}"][:] for k in range(4)]

    def streamed():
        for _ in iter_blocks(src, dataclasses.replace(opts, columns=tuple(channels.values())),
                             rows=block_rows):
            pass

    def write(arrays, path):
        table = pa.table(dict(zip(channels, arrays, strict=True)))
        with pq.ParquetWriter(path, table.schema, **parquet_options(table.schema)) as sink:
            for batch in table.to_batches(max_chunksize=block_rows):
                sink.write_table(pa.Table.from_batches([batch]))

    def digest_and_write():
        sha256(src)
        write(read(), out)

    held = read()  # the arrays of the write alone, read once
    floor, imported = "nptdms.TdmsFile.read (floor)", "import -> parquet"
    digest, parquet = "SHA-256 of the file", "Parquet write of the arrays (record's options)"
    least = "read + SHA-256 + Parquet write (no checks)"
    detail: dict = {}
    runs = common.interleaved({
        floor: read,
        digest: lambda: sha256(src),
        parquet: lambda: write(held, written),
        least: digest_and_write,
        "iter_blocks": streamed,
        imported: lambda: import_recording(src, opts, kind="noise", channels=channels, out=out,
                                           rows=block_rows),
    }, repeats, detail=detail)
    notes = {name: f"{rows / common.median(t) / 1e6:.3g} M rows/s" for name, t in runs.items()}
    by_name = {r.name: r for r in common.figures(runs, detail, floor=floor, notes=notes)}
    size = src.stat().st_size / 2**20
    report.add(common.markdown(
        list(by_name.values()), f"A TDMS file of {rows:,} rows x 4 channels ({size:.0f} MiB, "
        f"segments of {TDMS_SEGMENT:,} rows), blocks of {block_rows:,} rows "
        f"(median of {repeats})", floor_name="npTDMS"))

    def cpu(name):
        return common.median(detail[name].cpu)

    parts = by_name[floor].ratio + by_name[digest].ratio + by_name[parquet].ratio
    parts_cpu = (cpu(floor) + cpu(digest) + cpu(parquet)) / cpu(floor)
    report.add(common.pairs([
        ("import -> parquet / nptdms.TdmsFile.read, median wall times (target <= 3)",
         f"{by_name[imported].ratio:.2f}"),
        ("import -> parquet / nptdms.TdmsFile.read, median CPU times",
         f"{by_name[imported].cpu_ratio:.2f}"),
        ("the floor's parts / the read, wall (CPU): SHA-256 of the file",
         f"{by_name[digest].ratio:.2f} ({by_name[digest].cpu_ratio:.2f})"),
        ("the floor's parts / the read, wall (CPU): Parquet write of the arrays",
         f"{by_name[parquet].ratio:.2f} ({by_name[parquet].cpu_ratio:.2f})"),
        ("read + SHA-256 + Parquet write, the parts timed apart, summed / the read, wall (CPU)",
         f"{parts:.2f} ({parts_cpu:.2f})"),
        (("read + write, the SHA-256 on the other core (the least wall time on 2 idle cores) "
         "/ the read"), f"{by_name[floor].ratio + by_name[parquet].ratio:.2f}"),
        (("read + SHA-256 + Parquet write in one run (the least an import does) / the read, "
         "wall (CPU)"), f"{by_name[least].ratio:.2f} ({by_name[least].cpu_ratio:.2f})"),
        ("import -> parquet / (read + SHA-256 + Parquet write), median wall (CPU) times",
         (f"{common.median(runs[imported]) / common.median(runs[least]):.2f} "
         f"({cpu(imported) / cpu(least):.2f})")),
        ("the target (import at most 3x the read, wall)", _verdict(
            by_name[imported].ratio, by_name[floor].ratio + by_name[parquet].ratio, parts)),
    ], f"TDMS import speed, {rows:,} rows: summary"))


def _verdict(ratio: float, overlapped: float, parts: float) -> str:
    """Whether the import is within 3x of the read, and if not, whether the floor is."""
    if ratio <= 3:
        return f"met ({ratio:.2f})"
    if overlapped > 3:
        return (f"not met ({ratio:.2f}); not reachable here: the read and the Parquet write "
                f"alone take {overlapped:.2f}x the read ({parts:.2f}x with the SHA-256)")
    return (f"not met ({ratio:.2f}); the read and the Parquet write alone take "
            f"{overlapped:.2f}x the read ({parts:.2f}x with the SHA-256)")


_CHILD = """
import json, resource, sys, time
from accelcal.io.recordings import InputOptions
from accelcal.io.recordings.convert import import_recording

start = time.perf_counter()
import_recording(sys.argv[1], InputOptions(**{options!r}), kind="noise", channels={channels!r},
                 out=sys.argv[2], rows=int(sys.argv[3]))
print(json.dumps({{"seconds": time.perf_counter() - start,
                  "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}}))
"""


_MEASURE = """
import json, os, subprocess, sys
proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.PIPE, text=True)
out = proc.stdout.read()
_, status, ru = os.wait4(proc.pid, 0)
if os.waitstatus_to_exitcode(status):
    sys.exit(f"the import failed with status {os.waitstatus_to_exitcode(status)}")
print(json.dumps({**json.loads(out), "peak_mib": ru.ru_maxrss / 1024}))
"""
"""Runs the import's child from a small process and takes its peak from ``os.wait4``: the
child's own ``ru_maxrss`` would start from the resident memory of the process that spawned
it (see :data:`_LAUNCH`), here this benchmark's, holding the TDMS arrays of the speed
section."""


def _peak(src: Path, block_rows: int) -> dict:
    """Wall time and peak resident memory of one import of ``src``, in a fresh subprocess."""
    import sys

    code = _CHILD.format(options=OPTIONS, channels=CHANNELS)
    out = src.with_suffix(".parquet")
    result = common.child_json(_MEASURE, sys.executable, "-c", code, src, out, block_rows)
    out.unlink()
    return result


def bench_memory(report: common.Report, src: Path, rows: int, block_rows: int) -> None:
    """Peak resident memory of importing ``rows``, 4 x and 8 x ``rows`` rows, each in a new
    process; each larger CSV is removed once imported."""
    load = os.getloadavg()[0]
    peaks = {rows: _peak(src, block_rows)}
    for factor in (4, 8):
        large = src.with_name(f"daq{factor}.csv")
        write_csv(large, factor * rows)
        peaks[factor * rows] = _peak(large, block_rows)
        large.unlink()
    report.add(common.pairs([
        *((f"peak resident memory, {n:,} rows",
           f"{p['peak_mib']:.0f} MiB ({p['seconds']:.1f} s)") for n, p in peaks.items()),
        (f"ratio of the peaks, {4 * rows:,} / {rows:,} rows",
         f"{peaks[4 * rows]['peak_mib'] / peaks[rows]['peak_mib']:.2f}"),
        (f"ratio of the peaks, {8 * rows:,} / {4 * rows:,} rows (bounded memory: ~1)",
         f"{peaks[8 * rows]['peak_mib'] / peaks[4 * rows]['peak_mib']:.2f}"),
        ("load before the runs (1 min)", f"{load:.2f} on {common.cpus()} CPUs"),
    ], f"Import memory: import -> parquet in blocks of {block_rows:,} rows "
       "(fresh subprocess each, one run)"))


DETECT_COLUMNS = ("ax", "ay", "az")
"""The triad recording's channels (and ``t``, seconds)."""
DETECT_CLI = ("--columns", ",".join(DETECT_COLUMNS), "--time", "t", "--time-unit", "s",
              "--unit", "m/s^2", "--format", "csv")
"""How ``triad detect`` reads it."""
_READ = "import sys, pyarrow.parquet as pq; pq.read_table(sys.argv[1])"


def write_triad(path: Path, rows: int, rate: float = 1000.0, group: int = 1 << 20) -> None:
    """A triad held still at six positions in turn (60 s each, 2 s turns), written in row groups."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng(0)
    ups = np.array([(0, 0, 1), (1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0), (0, 0, -1)], float)
    hold, turn = round(60 * rate), round(2 * rate)
    cycle = []
    for k in range(6):
        a, b = ups[k], ups[(k + 1) % 6]
        s = np.linspace(0.0, 1.0, turn)[:, None]
        path_ = (1 - s) * a + s * b + 0.3 * np.sin(np.pi * s)
        cycle += [np.tile(a, (hold, 1)), path_ / np.linalg.norm(path_, axis=1, keepdims=True)]
    cycle = 9.80665 * np.concatenate(cycle)
    with pq.ParquetWriter(path, pa.schema([(c, pa.float64()) for c in ("t", *DETECT_COLUMNS)]),
                          compression="lz4") as writer:
        for a in range(0, rows, group):
            idx = np.arange(a, min(a + group, rows))
            u = cycle[idx % len(cycle)] + rng.normal(0.0, 0.01, (len(idx), 3))
            writer.write_table(pa.table({"t": idx / rate,
                                         **{c: u[:, k] for k, c in enumerate(DETECT_COLUMNS)}}))


_LAUNCH = """
import json, os, subprocess, sys
proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
_, status, ru = os.wait4(proc.pid, 0)
print(json.dumps({"status": os.waitstatus_to_exitcode(status),
                  "cpu": ru.ru_utime + ru.ru_stime, "peak_mib": ru.ru_maxrss / 1024}))
"""
"""Runs a command and prints its CPU seconds and peak resident memory. A small launcher: a
child's ``ru_maxrss`` starts from the resident memory of the process that spawned it (Linux
carries it across ``exec``), which would be this benchmark's, holding the recordings."""


def _child(cmd: list, usage: list) -> None:
    """Run ``cmd`` (output discarded) and keep its CPU seconds and peak resident MiB."""
    out = common.child_json(_LAUNCH, *cmd)
    if out["status"]:
        raise SystemExit(f"{cmd[:6]} failed with status {out['status']}")
    usage.append((out["cpu"], out["peak_mib"]))


def bench_detect(report: common.Report, tmp: Path, sizes, repeats: int) -> None:
    """``triad detect`` against a read of the same Parquet file, each in a fresh process."""
    import sys

    summary = []
    for rows in sizes:
        path = tmp / f"triad{rows}.parquet"
        write_triad(path, rows)
        floor, ours = "pyarrow.parquet.read_table (floor)", "accelcal triad detect"
        usage = {floor: [], ours: []}
        commands = {floor: [sys.executable, "-c", _READ, str(path)],
                    ours: [sys.executable, "-m", "accelcal", "triad", "detect", str(path),
                           *DETECT_CLI]}
        detail: dict = {}
        runs = common.interleaved(
            {name: functools.partial(_child, commands[name], usage[name]) for name in commands},
            repeats, detail=detail)
        cpu = {name: common.median([u[0] for u in usage[name]]) for name in usage}
        peak = {name: max(u[1] for u in usage[name]) for name in usage}
        notes = {name: f"child CPU {cpu[name]:.3g} s; peak RSS {peak[name]:.0f} MiB"
                 for name in usage}
        by_name = {r.name: r for r in common.figures(runs, detail, floor=floor, notes=notes,
                                                     cpu_ratios=False)}
        size = path.stat().st_size / 2**20
        report.add(common.markdown(
            list(by_name.values()), f"A triad recording of {rows:,} rows x (t + 3 channels) in "
            f"Parquet ({size:.0f} MiB), each run a fresh process (median of {repeats})",
            floor_name="read"))
        summary += [
            (f"{rows:,} rows: triad detect / read, median wall times (target <= 2)",
             f"{by_name[ours].ratio:.2f}"),
            (f"{rows:,} rows: triad detect / read, median child CPU times",
             f"{cpu[ours] / cpu[floor]:.2f}"),
            (f"{rows:,} rows: triad detect, peak resident memory (target < 300 MiB)",
             f"{peak[ours]:.0f} MiB (the read: {peak[floor]:.0f} MiB)"),
        ]
        path.unlink()
    report.add(common.pairs(summary, "Triad detect: summary"))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("sections", nargs="*", choices=["speed", "memory", "detect", []],
                        default=[])
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--tdms-rows", type=float, nargs="+", default=[2e6, 8e6],
                        help="speed: rows of each TDMS file (default 2e6 and 8e6)")
    parser.add_argument("--repeats", "--repeat", type=int, default=5,
                        help="speed: interleaved repeats (>= 5)")
    parser.add_argument("--block-rows", type=int, default=1 << 20)
    parser.add_argument("--detect-rows", type=float, nargs="+", default=[1e7, 4e7],
                        help="detect: rows of each triad recording")
    common.add_docs_option(parser)
    args = parser.parse_args(argv)
    sections = args.sections or ["speed", "memory"]
    report = common.Report("import")
    print(common.describe(report.start))
    with tempfile.TemporaryDirectory() as tmp:
        if "speed" in sections or "memory" in sections:
            src = Path(tmp) / "daq.csv"
            write_csv(src, args.rows)
            if "speed" in sections:
                bench_speed(report, src, args.rows, args.block_rows, args.repeats)
                for tdms_rows in args.tdms_rows:
                    tdms = Path(tmp) / "daq.tdms"
                    write_tdms(tdms, int(tdms_rows))
                    bench_tdms(report, tdms, int(tdms_rows), args.block_rows, args.repeats)
                    tdms.unlink()
            if "memory" in sections:
                bench_memory(report, src, args.rows, args.block_rows)
            report.finish(args.update_docs)
        if "detect" in sections:
            # its own section of the docs (import.detect), so that either can be rerun
            detect = common.Report("import.detect", "import.py detect")
            bench_detect(detect, Path(tmp), [int(r) for r in args.detect_rows], args.repeats)
            detect.finish(args.update_docs)


if __name__ == "__main__":
    main()
