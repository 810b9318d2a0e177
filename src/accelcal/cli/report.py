"""``accelcal report``: an HTML report of calibration records."""

from pathlib import Path

import typer


def report(
    records: list[Path] = typer.Argument(
        ..., help="Calibration record files (JSON, from a reduction's --record), triad "
        "calibration files (triad calibrate --out) and reductions' JSON outputs (--format "
        "json); any other file accelcal writes is named with what to give instead."),
    *,
    out: Path = typer.Option(..., "--out", help="HTML file to write (self-contained)."),
    title: str = typer.Option("Accelerometer calibration report", "--title", help="Page title."),
    data: list[Path] = typer.Option(
        [], "--data", help="A directory holding the records' input files (found by name and "
        "SHA-256, also in subdirectories two levels deep), for the figures; the records' own "
        "directories and the working directory are searched first. Repeatable."),
    history: bool = typer.Option(
        False, "--history", help="Add each serial number's calibration history from the store "
        "(coefficients against date, repeatability), one section per serial and method."),
    db: str | None = typer.Option(
        None, "--db", help="Store for --history: an SQLite file path or a database URL. "
        "Default: $ACCELCAL_DB, else ~/.local/share/accelcal/records.sqlite."),
    skip_bad: bool = typer.Option(
        False, "--skip-bad", help="With --history: leave out rows of the store that fail "
        "validation (changed outside accelcal) and count them, instead of refusing."),
    lab: Path | None = typer.Option(
        None, "--lab", help="Lab file (TOML, examples/lab.toml): each calibration record's "
        "uncertainty budget (as accelcal budget makes it) goes into an annex, and the "
        "summary's U is the budget's, with its k."),
) -> None:
    """Write a self-contained HTML report: the same sections as the demo's.

    The page opens with a summary table (per serial number, the key
    coefficients in µg, ppm, µrad, µg/g² with their expanded uncertainty),
    then one section per test, then an appendix (each sensor's record of a
    several-sensor test, the corrections to the published methods). Records
    of one reduction (the sensors of one indexing-head run) share a
    section with every sensor's coefficients in engineering units, the
    method's summary, figures and the paper's errata; the figures are drawn
    from the input files the records name by SHA-256, reduced again (when
    they are not found, or do not reproduce the record, the section says
    so). Every file is read and validated before the report is written; the
    file is written atomically. With --history, the store's hash chain is
    verified and its status line ('chain verified: yes (n records)') printed
    and written in each history section. With --lab, every calibration
    record's uncertainty budget (:func:`accelcal.report.budgets.record_budgets`)
    is in an annex and gives the summary's U and k.
    """
    from accelcal.report import write_report
    from accelcal.report.inputs import report_sections

    if (db is not None or skip_bad) and not history:
        from accelcal.errors import AccelcalError

        raise AccelcalError(f"{'--db' if db is not None else '--skip-bad'} goes with --history")
    sections = report_sections(records, search=data)
    chain = None
    budgets = None
    if lab is not None:
        from accelcal.budget.lab import load_lab
        from accelcal.report.budgets import record_budgets

        budgets = record_budgets(records, load_lab(lab), search=data)
    if history:
        from accelcal.report.sections import history_section
        from accelcal.store import Store

        pairs = dict.fromkeys((s.record.serial, s.record.method) for s in sections
                              if s.record is not None)
        with Store(db, readonly=True, skip_bad=skip_bad) as store:
            chain = store.verify().status_line()
            for serial, method in pairs:
                section = history_section(store, serial, method=method, chain=chain)
                if section is not None:
                    sections.append(section)
            skipped = store.skipped
        typer.echo(chain)
        if skipped:
            typer.echo(f"skipped {skipped} bad row{'s' * (skipped != 1)}", err=True)
    kept = {} if chain is None else {
        "records_chain": f"record files (not from a store); the history's store: {chain}"}
    write_report(out, sections, title=title, budgets=budgets, **kept)
    typer.echo(f"wrote {out}")
