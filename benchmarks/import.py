"""Import speed: a DAQ's CSV made into a Parquet record, against pyarrow reading the same CSV.

Run from the repository root::

    python benchmarks/import.py                 # 2,000,000 rows x (t + 4 channels)
    python benchmarks/import.py --rows 500000 --repeat 7

A CSV recording (a time column in ms and four channels in g, written once
by pyarrow) is

- ``pyarrow.csv.read_csv``: parsed whole by Arrow (the floor: no checks, the
  table held whole);
- ``iter_blocks``: streamed through :func:`accelcal.io.recordings.iter_blocks`
  (the same Arrow parser in blocks, plus the checks: finite values,
  increasing time);
- ``read_recording``: the same, held whole;
- ``import -> parquet``: :func:`accelcal.io.recordings.convert.import_recording`
  to a noise record (streamed, gap check, SHA-256 of the source, Parquet
  row groups, the record streamed back to validate it).

Candidates run interleaved (A, B, C, D, A, ...) ``--repeat`` times; the
median wall time is printed with the machine's load average (os.getloadavg,
1 minute) measured beside it: on a shared machine the figures move with the
load.
"""

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def write_csv(path: Path, rows: int) -> None:
    import pyarrow as pa
    from pyarrow import csv

    rng = np.random.default_rng(0)
    table = pa.table({"t_ms": np.arange(rows, dtype=float),
                      **{f"a{k}": rng.normal(0.0, 1e-3, rows) + (k == 2) for k in range(4)}})
    csv.write_csv(table, path)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--block-rows", type=int, default=1 << 20)
    args = parser.parse_args(argv)

    from pyarrow import csv

    from accelcal.io.recordings import InputOptions, iter_blocks, read_recording
    from accelcal.io.recordings.convert import import_recording

    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "daq.csv"
        write_csv(src, args.rows)
        opts = InputOptions(columns=("a0", "a1", "a2", "a3"), time="t_ms", time_unit="ms",
                            unit="g")
        out = Path(tmp) / "rec.parquet"

        def streamed():
            for _ in iter_blocks(src, opts, rows=args.block_rows):
                pass

        candidates = {
            "pyarrow.csv.read_csv": lambda: csv.read_csv(src),
            "iter_blocks": streamed,
            "read_recording": lambda: read_recording(src, opts),
            "import -> parquet": lambda: import_recording(
                src, opts, kind="noise", channels={f"c{k}": f"a{k}" for k in range(4)},
                out=out, rows=args.block_rows),
        }
        times = {k: [] for k in candidates}
        loads = {k: [] for k in candidates}
        for _ in range(args.repeat):
            for name, fn in candidates.items():
                start = time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - start)
                loads[name].append(os.getloadavg()[0])
        size = src.stat().st_size / 2**20
        print(f"{args.rows} rows x 5 columns, {size:.0f} MiB CSV; {args.repeat} interleaved "
              f"repeats; {os.cpu_count()} CPUs")
        floor = statistics.median(times["pyarrow.csv.read_csv"])
        for name in candidates:
            med = statistics.median(times[name])
            print(f"{name:22s} median {med:7.3f} s  {args.rows / med / 1e6:6.2f} M rows/s  "
                  f"{med / floor:5.2f} x pyarrow  load {statistics.median(loads[name]):.2f}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
