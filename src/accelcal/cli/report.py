"""``accelcal report``: an HTML report of calibration records."""

from pathlib import Path

import typer


def report(
    records: list[Path] = typer.Argument(..., help="Calibration record files (JSON)."),
    out: Path = typer.Option(..., "--out", help="HTML file to write (self-contained)."),
    title: str = typer.Option("Accelerometer calibration report", "--title", help="Page title."),
) -> None:
    """Write a self-contained HTML report (tables with uncertainties, correlations, inputs).

    Every record is read and validated before the report is written; the
    file is written atomically.
    """
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.report import Section, write_report

    loaded = [CalibrationRecord.load(path) for path in records]
    sections = [Section(f"{r.serial}: {r.method}", r) for r in loaded]
    write_report(out, sections, title=title)
    typer.echo(f"wrote {out}")
