"""``accelcal records``: the store of calibration records."""

from pathlib import Path

import typer

from accelcal.cli.common import emit, emit_columns, rows_of

app = typer.Typer(
    help=(
        "Store calibration records and follow each serial number: history, "
        "repeatability and drift. Default store: an SQLite file in the user data "
        "directory ($ACCELCAL_DB overrides it)."
    ),
    no_args_is_help=True,
)

_DB_HELP = (
    "Store: an SQLite file path or a database URL (e.g. postgresql+psycopg://user@host/db). "
    "Default: $ACCELCAL_DB, else ~/.local/share/accelcal/records.sqlite."
)
_SKIP_HELP = ("Leave out rows of the store that fail validation (changed outside accelcal) and "
              "count them, instead of refusing.")
_METHOD_HELP = ("Only calibrations by this method, as 'records list' shows it "
                "(e.g. dividing-head/joint; an old id such as tumble-fourier also works).")


def _store(db: str | None, *, readonly: bool = False, skip_bad: bool = False):
    from accelcal.store import Store

    return Store(db, readonly=readonly, skip_bad=skip_bad)


def _skipped(store) -> None:
    """Say how many bad rows a read left out (standard error)."""
    if store.skipped:
        typer.echo(f"skipped {store.skipped} bad row{'s' * (store.skipped != 1)}", err=True)


@app.command("add")
def add(
    # Plain strings: typer's per-item conversion to Path costs more than adding the record.
    records: list[str] = typer.Argument(..., help="Calibration record files (JSON)."),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
) -> None:
    """Add calibration records to the store, all in one transaction.

    Every file is read and validated before anything is written. If one
    record cannot be added (it is in the store already, or given twice) or
    the store cannot be written, none is, and the message names the file.
    """
    from accelcal.io.calibration_record import CalibrationRecord

    loaded = [CalibrationRecord.load(Path(path)) for path in records]
    with _store(db) as store:
        ids = store.add_many(loaded, sources=records)
    typer.echo("\n".join(f"added {path} as record {row_id} (serial {record.serial})"
                         for path, record, row_id in zip(records, loaded, ids, strict=True)))


@app.command("list")
def list_(
    serial: str | None = typer.Option(None, "--serial", help="Only this serial number."),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    skip_bad: bool = typer.Option(False, "--skip-bad", help=_SKIP_HELP),
) -> None:
    """List stored calibrations, oldest first (superseded_by: the record correcting one)."""
    with _store(db, readonly=True, skip_bad=skip_bad) as store:
        columns = store.calibrations_columns(serial)
        _skipped(store)
    if not columns["id"] and fmt == "table":
        typer.echo("the store holds no calibration" + (f" of {serial}" if serial else ""))
        return
    emit_columns(columns, fmt, title="Calibrations")


@app.command("history")
def history(  # noqa: PLR0917 - one parameter per command-line option
    serial: str = typer.Argument(..., help="Serial number."),
    method: str | None = typer.Option(None, "--method", help=_METHOD_HELP),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Directory for the history figure (PNG and SVG)."
    ),
    skip_bad: bool = typer.Option(False, "--skip-bad", help=_SKIP_HELP),
) -> None:
    """Every coefficient of every calibration of SERIAL (estimate and standard uncertainty).

    A calibration corrected by another record ('records supersede') is
    listed with the id of its correction in superseded_by; the figure
    leaves it out. The coefficient column follows a coefficient across its
    renaming (a row recorded as K_F before and as K_F+K_OO after is
    coefficient K_F); each change of name is stated.
    """
    from accelcal.store.history import renamings

    with _store(db, readonly=True, skip_bad=skip_bad) as store:
        columns = store.history_columns(serial, method)
        _skipped(store)
        fixes = store.corrections(serial) if fmt == "table" else []
    emit_columns(columns, fmt, title=f"Coefficient history of {serial}")
    for fix in fixes:
        typer.echo(f"record {fix['id']} supersedes record {fix['supersedes']}: by {fix['who']} "
                   f"on {fix['stored_at']}, because {fix['why']}")
    for change in renamings(columns):
        typer.echo("note: " + change.text(), err=True)
    if plot is not None:
        from accelcal.plotting import save_figure
        from accelcal.plotting.records import history_figure

        current = [r for r in rows_of(columns) if r["superseded_by"] is None]
        figure = history_figure(current, serial)
        paths = save_figure(figure, plot, f"history-{_safe(serial)}")
        typer.echo("wrote " + ", ".join(map(str, paths)), err=True)


@app.command("show")
def show(
    record: str = typer.Argument(
        ..., help="A record's id in the store (as 'records list' shows it) or a calibration "
                  "record file (JSON)."),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """One calibration record's coefficients, each uncertainty with its Type A and Type B parts.

    std is the standard uncertainty; type_b the part the priors of the terms
    the reduction takes as zero contribute (null, n/a in the table, where
    the record states none), type_a = sqrt(std^2 - type_b^2) the part from the data; expanded
    is k std with the record's coverage factor k. A complex coefficient is
    shown by its magnitude.
    """
    from accelcal.errors import AccelcalError
    from accelcal.io.calibration_record import CalibrationRecord

    if record.isdigit() and not Path(record).exists():
        if not 0 < int(record) < 2**63:  # the store's ids (SQL integers)
            raise AccelcalError(f"no record with id {record[:30]} in the store")
        with _store(db, readonly=True) as store:
            rec = store.record(int(record))
    else:
        rec = CalibrationRecord.load(Path(record))
    emit(record_rows(rec), fmt,
         title=f"{rec.serial}, {rec.method}, {rec.date} (k = {rec.coverage_factor:.3g})")


def record_rows(rec) -> list[dict]:
    """The rows ``records show`` prints of a record: one per coefficient."""
    est = rec.polar().magnitude if rec.is_complex else rec.estimates
    return [{"coefficient": n, "estimate": float(v), "std": float(s), "type_a": float(a),
             "type_b": rec.type_b.get(n), "expanded": float(u), "unit": rec.units.get(n, "")}
            for n, v, s, a, u in zip(rec.names, est, rec.std, rec.type_a_std, rec.expanded,
                                     strict=True)]


@app.command("stats")
def stats(
    serial: str = typer.Argument(..., help="Serial number."),
    method: str | None = typer.Option(None, "--method", help=_METHOD_HELP),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    skip_bad: bool = typer.Option(False, "--skip-bad", help=_SKIP_HELP),
) -> None:
    """Repeatability (run-to-run SD) and drift (slope per year) of each coefficient, per method.

    Calibrations superseded by a correction are left out.
    """
    from dataclasses import asdict

    with _store(db, readonly=True, skip_bad=skip_bad) as store:
        rows = [asdict(s) for s in store.stats(serial, method)]
        _skipped(store)
    emit(rows, fmt, title=f"Repeatability and drift of {serial}")


@app.command("verify")
def verify(
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table or json."),
) -> None:
    """Check that no record was changed, inserted or deleted outside accelcal.

    Every record is hashed again and compared with the hash chained into the
    store's journal when it was stored; each record found changed, inserted
    or deleted is named (id, serial, method, date). On SQLite, PRAGMA
    integrity_check runs too; on PostgreSQL the chain and the count of
    records against the journal are what is checked. The last line is the
    chain's head hash: copied elsewhere (a certificate), it shows later that
    no record was removed from the end. Exit status 1 when anything is
    found, 0 when the store verifies.
    """
    import json

    from accelcal.errors import AccelcalError

    if fmt not in ("table", "json"):
        raise AccelcalError(f"--format must be table or json, not {fmt!r}")
    with _store(db, readonly=True) as store:
        report = store.verify()
    if fmt == "json":
        typer.echo(json.dumps({
            "verified": report.verified, "records": report.records,
            "superseded": report.superseded, "chained": report.chained,
            "integrity": report.integrity, "head": report.head,
            "findings": [{"kind": f.kind, "id": f.id, "serial": f.serial, "method": f.method,
                          "date": f.date, "detail": f.detail} for f in report.findings],
        }, indent=2))
    else:
        lines = [f.line() for f in report.findings]
        lines += [f"integrity check: {report.integrity}", report.status_line(),
                  f"head: {report.head}"]
        typer.echo("\n".join(lines))
    if not report.verified:
        raise typer.Exit(1)


@app.command("corrections")
def corrections(
    serial: str | None = typer.Option(None, "--serial", help="Only this serial number."),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """List the corrections ('records supersede'): which record supersedes which, who, when, why."""
    from accelcal.validation import check_label

    if serial is not None:
        check_label(serial, "serial number")
    with _store(db, readonly=True) as store:
        rows = store.corrections(serial)
    if not rows and fmt == "table":
        typer.echo("the store holds no correction" + (f" of {serial}" if serial else ""))
        return
    emit(rows, fmt, title="Corrections")


@app.command("supersede")
def supersede(
    record_id: int = typer.Argument(..., help="Id of the stored record to correct "
                                    "('records list' shows the ids)."),
    by: str = typer.Option(..., "--by", help="The corrected calibration record (JSON)."),
    who: str = typer.Option(..., "--who", help="Who makes the correction."),
    why: str = typer.Option(..., "--why", help="Why the record is corrected."),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
) -> None:
    """Correct a stored record: add the corrected one, superseding it (never edited in place).

    The old record stays in the store, marked in 'records history' as
    superseded; statistics and reports use the correction. Who, why and
    when are journalled and hash-chained with the new record.
    """
    from accelcal.io.calibration_record import CalibrationRecord

    record = CalibrationRecord.load(Path(by))
    with _store(db) as store:
        new_id = store.supersede(record_id, record, who=who, why=why, source=by)
    typer.echo(f"added {by} as record {new_id} (serial {record.serial}), superseding "
               f"record {record_id}")


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)
