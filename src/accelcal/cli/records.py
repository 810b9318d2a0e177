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
_METHOD_HELP = ("Only calibrations by this method, as 'records list' shows it "
                "(e.g. dividing-head/joint; an old id such as tumble-fourier also works).")


def _store(db: str | None, *, readonly: bool = False):
    from accelcal.store import Store

    return Store(db, readonly=readonly)


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
) -> None:
    """List stored calibrations, oldest first."""
    with _store(db, readonly=True) as store:
        columns = store.calibrations_columns(serial)
    if not columns["id"] and fmt == "table":
        typer.echo("the store holds no calibration" + (f" of {serial}" if serial else ""))
        return
    emit_columns(columns, fmt, title="Calibrations")


@app.command("history")
def history(
    serial: str = typer.Argument(..., help="Serial number."),
    method: str | None = typer.Option(None, "--method", help=_METHOD_HELP),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Directory for the history figure (PNG and SVG)."
    ),
) -> None:
    """Every coefficient of every calibration of SERIAL (estimate and standard uncertainty).

    The coefficient column follows a coefficient across its renaming (a row recorded as
    K_F before and as K_F+K_OO after is coefficient K_F); each change of name is stated.
    """
    from accelcal.store.history import renamings

    with _store(db, readonly=True) as store:
        columns = store.history_columns(serial, method)
    emit_columns(columns, fmt, title=f"Coefficient history of {serial}")
    for change in renamings(columns):
        typer.echo("note: " + change.text(), err=True)
    if plot is not None:
        from accelcal.plotting import save_figure
        from accelcal.plotting.records import history_figure

        figure = history_figure(rows_of(columns), serial)
        paths = save_figure(figure, plot, f"history-{_safe(serial)}")
        typer.echo("wrote " + ", ".join(map(str, paths)), err=True)


@app.command("stats")
def stats(
    serial: str = typer.Argument(..., help="Serial number."),
    method: str | None = typer.Option(None, "--method", help=_METHOD_HELP),
    db: str | None = typer.Option(None, "--db", help=_DB_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Repeatability (run-to-run SD) and drift (slope per year) of each coefficient, per method."""
    from dataclasses import asdict

    with _store(db, readonly=True) as store:
        rows = [asdict(s) for s in store.stats(serial, method)]
    emit(rows, fmt, title=f"Repeatability and drift of {serial}")


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)
