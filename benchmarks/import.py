"""Import: a DAQ's CSV made into a Parquet record, against pyarrow reading the same CSV.

Run from the repository root::

    python benchmarks/import.py                 # 2,000,000 rows x (t + 4 channels)
    python benchmarks/import.py speed --rows 500000 --repeats 7
    python benchmarks/import.py --update-docs   # also write docs/benchmarks.md (section import)

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

Each figure is the median of ``--repeats`` runs (default 5; ``--repeat`` is
the same option) timed interleaved by :func:`common.interleaved` (A, B, C,
D, A, ...), with its ratio to the floor, its rows per second, the 1-minute
load average and the other processes' CPU beside it.

The section ``memory`` runs ``import -> parquet`` of that CSV and of one of
4 x ``--rows`` rows, each once in a fresh subprocess, and gives each
process's peak resident memory (``resource.getrusage``, ``ru_maxrss``) and
wall time, and their ratio. The import holds a block at a time (and reads the
first 2^20 rows to tell the rate from the time column), so when both CSVs
hold more rows than that and than a block, as with the defaults (2 and 8
million rows, blocks of 2^20), the two peaks should match.

``--update-docs`` writes the tables into ``docs/benchmarks.md`` (section
``import``).
"""

import common  # noqa: I001  (first: it pins BLAS to one thread before numpy loads)

import argparse
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


def _peak(src: Path, block_rows: int) -> dict:
    """Wall time and peak resident memory of one import of ``src``, in a fresh subprocess."""
    code = _CHILD.format(options=OPTIONS, channels=CHANNELS)
    out = src.with_suffix(".parquet")
    result = common.child_json(code, src, out, block_rows)
    out.unlink()
    return result


def bench_memory(report: common.Report, src: Path, rows: int, block_rows: int) -> None:
    """Peak resident memory of importing ``rows`` and 4 x ``rows`` rows, each in a new process."""
    large = src.with_name("daq4.csv")
    write_csv(large, 4 * rows)
    load = os.getloadavg()[0]
    small_peak, large_peak = _peak(src, block_rows), _peak(large, block_rows)
    report.add(common.pairs([
        (f"peak resident memory, {rows:,} rows",
         f"{small_peak['peak_mib']:.0f} MiB ({small_peak['seconds']:.1f} s)"),
        (f"peak resident memory, {4 * rows:,} rows",
         f"{large_peak['peak_mib']:.0f} MiB ({large_peak['seconds']:.1f} s)"),
        ("ratio of the peaks (bounded memory: ~1 above a block and 2^20 rows)",
         f"{large_peak['peak_mib'] / small_peak['peak_mib']:.2f}"),
        ("load before the runs (1 min)", f"{load:.2f} on {common.cpus()} CPUs"),
    ], f"Import memory: import -> parquet in blocks of {block_rows:,} rows "
       "(fresh subprocess each, one run)"))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("sections", nargs="*", choices=["speed", "memory", []], default=[])
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--repeats", "--repeat", type=int, default=5,
                        help="speed: interleaved repeats (>= 5)")
    parser.add_argument("--block-rows", type=int, default=1 << 20)
    common.add_docs_option(parser)
    args = parser.parse_args(argv)
    sections = args.sections or ["speed", "memory"]
    report = common.Report("import")
    print(common.describe(report.start))
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "daq.csv"
        write_csv(src, args.rows)
        if "speed" in sections:
            bench_speed(report, src, args.rows, args.block_rows, args.repeats)
        if "memory" in sections:
            bench_memory(report, src, args.rows, args.block_rows)
    report.finish(args.update_docs)


if __name__ == "__main__":
    main()
