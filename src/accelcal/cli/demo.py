"""``accelcal demo``: a full simulated calibration campaign, reduced, stored and reported."""

from pathlib import Path

import typer


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

    Indexing head with four sensors (Dong2014), shaker transverse sweep
    (GuanTang) and vibrafuge grid (Guan2021): input files, calibration
    records, the store and a self-contained HTML report. Each run is dated,
    so running it again adds new records and the report shows the history.
    """
    from accelcal.demo import run

    result = run(out, db=db, seed=seed, progress=True)
    typer.echo(f"report:  {result.report}")
    typer.echo(f"figures: {out / 'figures'} ({len(result.figures)} SVG files)")
    typer.echo(f"records: {out / 'records'} ({len(result.records)} calibration records)")
    typer.echo(f"data:    {out / 'data'} (the record file of each test)")
    typer.echo(f"store:   {result.store} (record ids "
               f"{', '.join(map(str, result.record_ids))})")
    typer.echo(f"seed:    {result.seed} (repeat with --seed {result.seed})")
    typer.echo(f"done in {result.seconds:.1f} s")
