"""``accelcal demo``: a full simulated calibration campaign, reduced, stored and reported."""

from pathlib import Path

import typer

from accelcal.catalog import demo_methods, listed


def demo(
    out: Path = typer.Option(
        Path("accelcal-demo"), "--out",
        help="Output directory (created): data/, records/, figures/, report.html and the "
             "store records.sqlite."),
    db: str | None = typer.Option(
        None, "--db", help="Store for the records: an SQLite file path or a database URL. "
        "Default: OUT/records.sqlite; the demo never writes to your records store "
        "($ACCELCAL_DB or ~/.local/share/accelcal/records.sqlite) unless named here."),
    seed: int | None = typer.Option(
        None, "--seed", help="Seed of the simulated errors and noise (integer); default a "
        "fresh one, printed."),
) -> None:
    """Simulate a calibration campaign of the default accelerometer, reduce it, store and report.

    The full help, which names the tests the campaign runs, is :func:`_help`'s.
    """
    from accelcal.demo import certify, run

    result = run(out, db=db, seed=seed, progress=True)
    cert = certify(result)
    typer.echo(cert.budget.rstrip("\n"))
    typer.echo("")
    typer.echo(f"report:  {result.report}")
    typer.echo(f"figures: {out / 'figures'} ({len(result.figures)} SVG files)")
    typer.echo(f"records: {out / 'records'} ({len(result.records)} calibration records)")
    typer.echo(f"data:    {out / 'data'} (the record file of each test)")
    typer.echo(f"store:   {result.store} (record ids "
               f"{', '.join(map(str, result.record_ids))})")
    typer.echo(f"lab:     {cert.lab} (the standards the budgets use)")
    typer.echo(f"certificate {cert.number}: "
               f"{', '.join(str(p) for p in cert.files)}")
    typer.echo(f"seed:    {result.seed} (repeat with --seed {result.seed})")
    typer.echo(f"done in {result.seconds:.1f} s")


def _help() -> str:
    """The command's help: the tests it runs, from the methods' descriptors."""
    tests = listed((f"{m.demo_test} ({m.paper})" for m in demo_methods()), "and")
    return ("Simulate a calibration campaign of the default accelerometer, reduce it, store and "
            f"report.\n\nThe tests, in order: {tests}. It writes the input files, the "
            "calibration records, the store and a self-contained HTML report, then a lab file, "
            "the uncertainty budget of one result and a calibration certificate of the "
            "indexing-head sensors and the frequency response (HTML, JSON, and PDF where "
            "WeasyPrint is installed). Each run "
            "is dated, so running it again adds new records and the report shows the history.")


demo.__doc__ = _help()
