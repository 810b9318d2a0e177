"""The records store: ``records add`` of many files, and queries of a 100k-record store.

Run from the repository root::

    python benchmarks/store.py                       # everything (a few minutes)
    python benchmarks/store.py --records 20000 --repeats 5

Timed whole, in-process, as a user calls them:

- ``accelcal records add`` of 1, 199 and 10,000 record files in one call,
  each into an empty SQLite store made beforehand, untimed (the files are
  read and validated, the store opened, the records written), and the bulk
  API, :meth:`Store.add_many`, with the store's opening, of the same records
  already in memory;
- ``accelcal records list``, ``history`` and ``stats`` (``--format csv``,
  output to memory) and the :class:`~accelcal.store.Store` calls under them,
  on a store of ``--records`` records: serial ``SN-A`` holds all of them but
  ten, in two methods (so ``list`` lists them all, ``history SN-A`` gives
  three coefficients each and ``stats SN-A`` pools them), ``SN-B`` holds ten
  (the indexed look-up of a few among many). The store is built with the
  bulk API (or, on an accelcal without it, by inserting the same rows
  directly).

Each figure is the median of ``--repeats`` runs timed interleaved by
:func:`common.interleaved`, with the machine's one-minute load beside it and
figures taken under load flagged; ``--update-docs`` writes the tables into
``docs/benchmarks.md``.
"""

import common  # noqa: I001  (first: it pins BLAS to one thread before numpy loads)

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _records(n: int, serial: str = "SN-A", methods=("dividing-head/joint", "tumble/six")):
    """``n`` distinct records of ``serial`` a minute apart, alternating between ``methods``."""
    import datetime as dt

    from accelcal.io.calibration_record import CalibrationRecord

    start = dt.datetime(2020, 1, 1, tzinfo=dt.UTC)
    rng = np.random.default_rng(7)
    shifts = rng.normal(0.0, 1e-6, (n, 3))
    base = np.array([-8.3e-4, 1.2993698, -1.2e-5])
    cov = np.diag([1.0e-12, 4.0e-12, 9.0e-12])
    units = {"K_F": "V", "K_I": "V/g", "K_O": "V"}
    return [
        CalibrationRecord(
            serial=serial, method=methods[i % len(methods)], names=("K_F", "K_I", "K_O"),
            estimates=base + shifts[i], covariance=cov, units=units,
            date=(start + dt.timedelta(minutes=i)).isoformat(), software="accelcal bench",
        )
        for i in range(n)
    ]


def _fill(store, records) -> None:
    """Add ``records`` with the bulk API, or row by row in one transaction without it."""
    if hasattr(store, "add_many"):
        store.add_many(records)
        return
    import hashlib
    import math

    import sqlalchemy as sa

    from accelcal.store import _utc

    cal, coef = store._tables["calibrations"], store._tables["coefficients"]
    with store.engine.begin() as conn:
        for r in records:
            text = r.to_json()
            row_id = conn.execute(sa.insert(cal).values(
                uid=hashlib.sha256(text.encode()).hexdigest(), serial=r.serial,
                method=r.method, simulated=False, date=_utc(r.date), software=r.software,
                record_json=text).returning(cal.c.id)).scalar_one()
            conn.execute(sa.insert(coef), [
                {"calibration_id": row_id, "name": n, "unit": r.units.get(n, ""),
                 "estimate": float(v), "std": None if math.isnan(s) else float(s)}
                for n, v, s in zip(r.names, r.estimates, r.std, strict=True)])


def _cli(*args) -> str:
    """Run ``accelcal ARGS`` in-process; return its standard output (exit status 0 checked)."""
    from accelcal.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            main([str(a) for a in args])
        except SystemExit as exc:
            if exc.code not in (0, None):
                raise RuntimeError(
                    f"accelcal {' '.join(map(str, args[:3]))} exited {exc.code}") from None
    return out.getvalue()


def bench_add(report: common.Report, work: Path, sizes: list[int], repeats: int) -> None:
    from accelcal.store import Store

    records = _records(max(sizes), serial="SN-ADD")
    files = []
    for i, record in enumerate(records):
        path = work / f"rec-{i:05d}.json"
        record.save(path)
        files.append(path)
    # One empty store per call, made beforehand: the figures are of adding, not creating.
    empty = iter([work / f"a{k}.db" for k in range(2 * len(sizes) * repeats)])
    pool = []
    for _ in range(2 * len(sizes) * repeats):
        pool.append(next(empty))
        Store(pool[-1]).close()
    stores = iter(pool)

    def add_cli(n):
        return lambda: _cli("records", "add", *files[:n], "--db", next(stores))

    def add_api(n):
        def go():
            with Store(next(stores)) as store:
                _fill(store, records[:n])
        return go

    candidates, per = {}, {}
    for n in sizes:
        candidates[f"records add, {n:,} files"] = add_cli(n)
        candidates[f"Store.add_many, {n:,} records"] = add_api(n)
        per[f"records add, {n:,} files"] = per[f"Store.add_many, {n:,} records"] = n
    detail = {}
    runs = common.interleaved(candidates, repeats, detail=detail)
    notes = {name: f"{common.median(runs[name]) / per[name] * 1e3:.3g} ms per record"
             for name in candidates}
    rows = common.figures(runs, detail, floor=f"records add, {sizes[0]:,} files", notes=notes)
    report.add(common.markdown(
        rows, f"Adding records to an empty SQLite store, one call (median of {repeats})",
        floor_name=f"{sizes[0]} file"))


def bench_queries(report: common.Report, work: Path, count: int, repeats: int) -> None:
    from accelcal.store import Store

    db = work / "big.db"
    start = time.perf_counter()
    with Store(db) as store:
        _fill(store, _records(count - 10) + _records(10, serial="SN-B"))
    report.add(f"Built a store of {count:,} records in {time.perf_counter() - start:.1f} s "
               "(bulk API).")
    rows = {}

    def api(name, fn):
        def go():
            with Store(db, readonly=True) as store:
                rows[name] = len(fn(store))
        return go

    candidates = {
        "records list (csv)": lambda: _cli("records", "list", "--db", db, "--format", "csv"),
        "records list --serial SN-B": lambda: _cli("records", "list", "--serial", "SN-B",
                                                   "--db", db, "--format", "csv"),
        "records history SN-A (csv)": lambda: _cli("records", "history", "SN-A", "--db", db,
                                                   "--format", "csv"),
        "records history SN-A --method": lambda: _cli(
            "records", "history", "SN-A", "--method", "tumble/six", "--db", db,
            "--format", "csv"),
        "records history SN-B": lambda: _cli("records", "history", "SN-B", "--db", db,
                                             "--format", "csv"),
        "records stats SN-A": lambda: _cli("records", "stats", "SN-A", "--db", db,
                                           "--format", "csv"),
        "records stats SN-B": lambda: _cli("records", "stats", "SN-B", "--db", db,
                                           "--format", "csv"),
        "Store.calibrations()": api("calibrations", lambda s: s.calibrations()),
        "Store.history('SN-A')": api("history", lambda s: s.history("SN-A")),
        "Store.stats('SN-A')": api("stats", lambda s: s.stats("SN-A")),
    }
    detail = {}
    runs = common.interleaved(candidates, repeats, detail=detail)
    report.add(common.markdown(common.figures(runs, detail),
                               f"Queries of a {count:,}-record store (median of {repeats})"))
    report.add(f"Rows returned: {rows}.")
    bench_history_floor(report, db, repeats)


_HISTORY_SQL = (
    "SELECT c.id, c.date, c.method, k.name, k.unit, k.estimate, k.std FROM calibrations c "
    "JOIN coefficients k ON k.calibration_id = c.id WHERE c.serial = ? "
    "ORDER BY c.date, c.id, k.id")
"""The rows of ``records history`` (as the store's query gives them), for the floors."""


def bench_history_floor(report: common.Report, db: Path, repeats: int) -> None:
    """``records history SN-A`` against what any Python writer of its CSV must do.

    Floors: the sqlite3 module's fetch of the same rows alone, and that fetch
    followed by the cheapest CSV text of them (``repr`` of the numbers,
    ``str.join``): no accelcal code at all.
    """
    import sqlite3
    from operator import itemgetter

    def fetch():
        with contextlib.closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True)) as con:
            return con.execute(_HISTORY_SQL, ("SN-A",)).fetchall()

    def fetch_and_format():
        rows = fetch()
        columns = [list(map(itemgetter(i), rows)) for i in range(len(rows[0]))]
        texts = [list(map(repr, col)) if isinstance(col[0], int | float) else col
                 for col in columns]
        return "\n".join(map(",".join, zip(*texts, strict=True)))

    floor, text, cli = ("sqlite3 fetch of the rows (floor)", "fetch + repr and join (floor)",
                        "records history SN-A (csv)")
    candidates = {floor: fetch, text: fetch_and_format,
                  cli: lambda: _cli("records", "history", "SN-A", "--db", db, "--format", "csv")}
    detail = {}
    runs = common.interleaved(candidates, repeats, detail=detail)
    report.add(common.markdown(common.figures(runs, detail, floor=floor),
                               f"records history of a serial with {len(fetch()):,} coefficient "
                               "rows, against its floors", floor_name="fetch"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--records", type=int, default=100_000)
    parser.add_argument("--sizes", default="1,199,10000", help="records add sizes")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--only", choices=("add", "queries"), default=None)
    common.add_docs_option(parser)
    args = parser.parse_args()
    import accelcal

    report = common.Report("store")
    print(f"accelcal {accelcal.__version__} from {Path(accelcal.__file__).parent}; "
          f"{common.describe(report.start)}")
    with tempfile.TemporaryDirectory(prefix="accelcal-bench-store-") as tmp:
        work = Path(tmp)
        if args.only in (None, "add"):
            bench_add(report, work, [int(s) for s in args.sizes.split(",")], args.repeats)
        if args.only in (None, "queries"):
            bench_queries(report, work, args.records, args.repeats)
    report.finish(args.update_docs)


if __name__ == "__main__":
    sys.exit(main())
