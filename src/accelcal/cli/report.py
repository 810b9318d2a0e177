"""``accelcal report``: an HTML report of calibration records."""

from pathlib import Path

import typer


def report(
    records: list[Path] = typer.Argument(..., help="Calibration record files (JSON)."),
    out: Path = typer.Option(..., "--out", help="HTML file to write (self-contained)."),
    title: str = typer.Option("Accelerometer calibration report", "--title", help="Page title."),
    history: bool = typer.Option(
        False, "--history", help="Add each serial number's calibration history from the store "
        "(coefficients against date, repeatability), one section per serial and method."),
    db: str | None = typer.Option(
        None, "--db", help="Store for --history: an SQLite file path or a database URL. "
        "Default: $ACCELCAL_DB, else ~/.local/share/accelcal/records.sqlite."),
) -> None:
    """Write a self-contained HTML report (tables with uncertainties, correlations, inputs).

    Every record is read and validated before the report is written; the
    file is written atomically.
    """
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.report import Section, write_report

    loaded = [CalibrationRecord.load(path) for path in records]
    sections = [Section(f"{r.serial}: {r.method}", r) for r in loaded]
    if history:
        from accelcal.report.sections import history_section
        from accelcal.store import Store

        with Store(db, readonly=True) as store:
            for serial, method in dict.fromkeys((r.serial, r.method) for r in loaded):
                section = history_section(store, serial, method=method)
                if section is not None:
                    sections.append(section)
    elif db is not None:
        from accelcal.errors import AccelcalError

        raise AccelcalError("--db goes with --history")
    write_report(out, sections, title=title)
    typer.echo(f"wrote {out}")
