"""``accelcal acceptance``: threshold, resolution and hysteresis tests (simulate, reduce)."""

from pathlib import Path

import typer

from accelcal.cli.common import check_format, check_writable, emit
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=("Acceptance tests of pendulous accelerometers on the indexing head (IEEE 1293): "
          "threshold and resolution by the 50 % rule with the decision's error probability, "
          "hysteresis over the input cycle; simulated records and their reduction."),
    no_args_is_help=True,
)

_TESTS = ("threshold", "resolution", "hysteresis")


def _check_test(test: str) -> None:
    if test not in _TESTS:
        raise AccelcalError(f"--test {test[:20]!r} is not one of {', '.join(_TESTS)}")


@app.command("simulate")
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Step record to write (CSV or .parquet)."),
    test: str = typer.Option("threshold", "--test",
                             help="threshold, resolution or hysteresis."),
    set_point: float | None = typer.Option(
        None, "--set-point", help="Set-point angle, deg (default 0 for the threshold, 30 for "
                                  "the resolution)."),
    increments: str = typer.Option("0.5,1,1.5,2,3,4,6,8,12", "--increments",
                                   help="Angle increments, arcsec, ascending."),
    reversals: int = typer.Option(3, "--reversals", min=1,
                                  help="Up-and-back pairs per increment."),
    cycle_step: float = typer.Option(15.0, "--cycle-step",
                                     help="Angle step of the hysteresis cycle, deg."),
    dwell: float = typer.Option(10.0, "--dwell", help="Time at each angle, s."),
    rate: float = typer.Option(10.0, "--rate", help="Sample rate, Hz."),
    noise: float = typer.Option(5.0, "--noise", help="Output noise SD per sample, ug."),
    breakaway: float = typer.Option(10.0, "--breakaway",
                                    help="Stick-slip break-away level at null, ug."),
    friction: float = typer.Option(20.0, "--friction",
                                   help="Growth of the break-away level, ug per g of set point."),
    hysteresis: float = typer.Option(20.0, "--hysteresis",
                                     help="Decreasing-minus-increasing output far from the "
                                          "turning points, ug."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the random generator."),
) -> None:
    """Write a simulated step test (its metadata: the true threshold, resolution or hysteresis)."""
    from accelcal.io.formats import acceptance as steps_format
    from accelcal.rigs.acceptance import simulate as simulate_steps

    _check_test(test)
    check_writable(out)
    try:
        ladder = tuple(float(v) for v in increments.split(","))
    except ValueError:
        raise AccelcalError(f"--increments {increments[:40]!r} is not a list of numbers "
                            "(arcsec)") from None
    record = simulate_steps(test, set_point=set_point, increments=ladder, reversals=reversals,
                            cycle_step=cycle_step, dwell=dwell, rate=rate, noise=noise * 1e-6,
                            breakaway=breakaway * 1e-6, friction=friction * 1e-6,
                            hysteresis=hysteresis * 1e-6, seed=seed)
    steps_format.write(out, record)
    typer.echo(f"wrote {out}")


@app.command("reduce")
def reduce(
    file: Path = typer.Argument(..., help="Step record (CSV or Parquet, kind steps)."),
    *,
    test: str | None = typer.Option(None, "--test", help="threshold, resolution or hysteresis "
                                                         "(default: the record's)."),
    settle: float = typer.Option(0.0, "--settle", help="Seconds dropped at the start of each "
                                                       "dwell."),
    max_error: float = typer.Option(
        0.05, "--max-error", help="Largest probability that the 50 % decision is wrong "
                                  "accepted; above it the dwells are too short."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = typer.Option(None, "--plot", help="Directory for the figures."),
) -> None:
    """Reduce a step test: rows quantity, estimate, std, unit (ug for accelerations)."""
    import sys

    from accelcal.methods import acceptance

    check_format(fmt)
    if test is not None:
        _check_test(test)
    red = acceptance.reduce(file, test=test, settle=settle, max_error=max_error)
    if plot is not None:
        for p in red.plot(plot):
            typer.echo(f"wrote {p}", err=True)
    emit(acceptance.quantity_rows(red), fmt,
         title=f"Acceptance test ({red.method}, {red.dof} dof), {file}")
    stream = sys.stdout if fmt == "table" else sys.stderr
    for note in red.estimate.notes:
        print(f"note: {note}", file=stream)
