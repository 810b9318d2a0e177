"""``accelcal tumble``: multipoint tumble identifiability, simulation and reduction."""

from pathlib import Path

import typer

from accelcal.cli.common import check_format, emit, load_model, parse_grid
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=(
        "Multipoint tumble (IEEE 1293 style): what a position set identifies, "
        "simulated records, and the Fourier / least-squares reduction."
    ),
    no_args_is_help=True,
)

_AXIS_HELP = (
    "Rotation axis: OA (a_i = cos theta, a_p = sin theta) or PA "
    "(a_i = sin theta, a_o = cos theta, the indexing head)."
)
_TERMS_HELP = (
    "Comma-separated model terms (K0,K1,K2,K3,K4, Kp,Kpp,Kip about OA or Ko,Koo,Kio about "
    "PA, K0_asym,K1_asym); coefficients in g/g^n, K1 in output unit per g."
)


def _angles_deg(points: int | None, angles: str | None, start: float) -> list[float]:
    import numpy as np

    from accelcal.rigs.tumble import uniform_positions

    if (points is None) == (angles is None):
        raise AccelcalError("give either --points N or --angles LIST (degrees), not both")
    if angles is not None:
        return parse_grid(angles, "--angles")
    uniform_positions(points, np.radians(start))  # checks the count and the memory it takes
    return (start + 360.0 * np.arange(points) / points).tolist()


def _terms(text: str | None):
    if text is None:
        return None
    items = [t.strip() for t in text.split(",")]
    if not all(items):
        raise AccelcalError(f"--terms {text!r} has an empty item; give names separated by commas")
    return tuple(items)


def _finite(x: float):
    import math

    return x if math.isfinite(x) else None


@app.command("identify")
def identify(
    *,
    points: int | None = typer.Option(
        None, "--points", help="Number of equally spaced positions (starting at --start)."
    ),
    angles: str | None = typer.Option(
        None, "--angles", help="Positions in degrees: a list 0,90,180 or a range 0:330:30."
    ),
    start: float = typer.Option(0.0, "--start", help="First position with --points, degrees."),
    axis: str = typer.Option("OA", "--axis", help=_AXIS_HELP),
    terms: str | None = typer.Option(
        None, "--terms", help=_TERMS_HELP + " Default: every term the axis excites."
    ),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Print which coefficients a position set can separate (rank, condition number)."""
    import json

    import numpy as np

    from accelcal.methods.tumble import identifiability

    check_format(fmt)
    deg = _angles_deg(points, angles, start)
    report = identifiability(np.radians(deg), axis, terms=_terms(terms))
    if fmt == "json":
        doc = {
            "rotation_axis": report.rotation_axis,
            "positions_deg": deg,
            "rank": report.rank,
            "unknowns": len(report.terms),
            "condition_number": _finite(report.condition_number),
            "condition_number_identifiable": _finite(report.condition_number_identifiable),
            "terms": report.rows(),
            "combinations": list(report.labels()),
            "suggested_terms": list(report.suggested_terms),
        }
        typer.echo(json.dumps(doc, indent=2))
        return
    if fmt == "table":
        typer.echo(report.summary())
        typer.echo("suggested terms: " + ",".join(report.suggested_terms))
    emit(report.rows(), fmt, title="Identifiability")


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Record file to write (CSV, kind tumble)."),
    points: int = typer.Option(24, "--points", help="Number of equally spaced positions."),
    start: float = typer.Option(0.0, "--start", help="First position, degrees."),
    axis: str = typer.Option("OA", "--axis", help=_AXIS_HELP),
    model_file: Path | None = typer.Option(
        None, "--model", help="Model file; default: the embedded default accelerometer."
    ),
    noise: float | None = typer.Option(
        None,
        "--noise",
        help="Noise SD of one reading, in the model's output unit (default: the model's sigma).",
    ),
    repeats: int = typer.Option(1, "--repeats", help="Readings per position (averaged)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random generator."),
    force: bool = FORCE,
) -> None:
    """Write a simulated tumble record (true model and noise in its metadata)."""
    import numpy as np

    from accelcal.io.formats import tumble as tumble_format
    from accelcal.rigs.tumble import simulate as simulate_tumble
    from accelcal.rigs.tumble import uniform_positions

    model = load_model(model_file)
    positions = uniform_positions(points, np.radians(start))
    record = simulate_tumble(positions, model, rotation_axis=axis, noise=noise,
                             repeats=repeats, seed=seed)
    tumble_format.write(out, record)
    typer.echo(f"wrote {out}")


@app.command("reduce")
def reduce(  # noqa: PLR0917 - one parameter per command-line option
    file: Path = typer.Argument(..., help="Tumble record file (CSV, kind tumble)."),
    terms: str | None = typer.Option(
        None,
        "--terms",
        help=_TERMS_HELP + " Default: K0,K1,K2,K3,K4 and the axis's cross-axis and "
        "cross-coupling terms.",
    ),
    route: str = typer.Option(
        "auto", "--route", help="auto, fourier (IEEE relations, uniform N >= 8) or lsq."
    ),
    sigma: float | None = typer.Option(
        None,
        "--sigma",
        help="Known noise SD of one reading, output unit (default: from the residuals).",
    ),
    priors: str = typer.Option(
        "default", "--priors",
        help="Priors of the terms taken as zero that the positions could separate: default "
        "(twice the embedded default accelerometer's magnitude, rectangular), none (state "
        "only how much each would move each row), or TERM=U,... (standard uncertainties in "
        "the term's unit), propagated as Type B.",
    ),
    asymmetry: str = typer.Option(
        "auto", "--asymmetry",
        help="Estimate K0' and K1' on the least-squares route: auto (where the positions "
        "separate them and no --terms are given), yes or no.",
    ),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Reduce a tumble record: estimate and standard uncertainty of each coefficient."""
    import sys

    from accelcal.aliasing import alias_text
    from accelcal.methods import tumble
    from accelcal.methods.tumble.unestimated import parse_asymmetry, parse_priors

    check_format(fmt)
    result = tumble.reduce(file, terms=_terms(terms), route=route, sigma=sigma,
                           asymmetry=parse_asymmetry(asymmetry), priors=parse_priors(priors))
    route_used = result.assumed("route")
    emit(result.rows(), fmt, title=f"Tumble reduction ({route_used}), {file}")
    lines = [
        f"combination {tumble.combination_label(c)} = {c.value:.10g} +- {c.std:.3g} {c.unit}"
        for c in result.combinations
    ]
    from accelcal.interval import statements

    lines += [f"note: {n}" for n in (*result.estimate.notes, *statements(result))]
    lines += [f"note: {n}" for n in alias_text(
        a for a in result.aliases if a.term not in {p.name for p in result.priors})]
    stream = sys.stdout if fmt == "table" else sys.stderr
    for line in lines:
        print(line, file=stream)
