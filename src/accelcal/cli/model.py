"""``accelcal model``: show, create and evaluate error-model files."""

from pathlib import Path

import typer

from accelcal.cli.common import emit, load_model, parse_grid
from accelcal.errors import AccelcalError

app = typer.Typer(
    help="Show, create and evaluate accelerometer error models (model files are JSON).",
    no_args_is_help=True,
)

_TERM_NAMES = "K0, K1, K2, K3, K4, Ko, Kp, Koo, Kpp, Kio, Kip, Kop, K0_asym, K1_asym, sigma"


@app.command("show")
def show(
    file: Path | None = typer.Argument(
        None, help="Model file (JSON). Without it, the embedded default accelerometer."
    ),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Print a model's coefficients with their units."""
    from accelcal.model import TERMS

    model = load_model(file)
    if fmt == "json":
        typer.echo(model.to_json(), nl=False)
        return
    units = model.units()
    rows = [
        {"term": name, "value": value, "unit": units[name], "description": TERMS[name].description}
        for name, value in model.terms().items()
    ]
    source = str(file) if file is not None else "embedded default accelerometer"
    emit(rows, fmt, title=f"Error model: {source} (output in {model.output_unit})")


@app.command("new")
def new(
    out: Path = typer.Option(..., "--out", help="Model file to write (JSON)."),
    set_: list[str] = typer.Option(
        [],
        "--set",
        metavar="NAME=VALUE",
        help=(
            f"Set a term (repeatable). NAME is one of {_TERM_NAMES}. Units: K1 in output "
            "unit per g, sigma in g, others in g/g^n. Terms not set are 0, except K1 = 1."
        ),
    ),
    output_unit: str = typer.Option(
        "V", "--output-unit", help="Output unit of the model: V, mV, mA or g."
    ),
) -> None:
    """Write a new model file from NAME=VALUE settings."""
    from accelcal.cli.common import parse_number
    from accelcal.io.limits import shown, shown_name
    from accelcal.model import ErrorModel

    terms: dict[str, float] = {}
    for item in set_:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise AccelcalError(f"--set {shown(item)} is not NAME=VALUE (e.g. --set K2=7.87e-6)")
        if name in terms:
            raise AccelcalError(f"--set gives {shown_name(name)} twice; give each term once")
        terms[name] = parse_number(value, f"--set {shown_name(name)}")
    model = ErrorModel.from_terms(terms, output_unit=output_unit)
    model.save(out)
    typer.echo(f"wrote {out}")


@app.command("eval")
def evaluate(
    ai: str = typer.Option(
        ...,
        "--ai",
        help="Specific force along IA, g: a number, a list 0,0.5,1 or a range -1:1:0.5.",
    ),
    ao: str = typer.Option("0", "--ao", help="Specific force along OA, g (number, list or range)."),
    ap: str = typer.Option("0", "--ap", help="Specific force along PA, g (number, list or range)."),
    model_file: Path | None = typer.Option(
        None, "--model", help="Model file; default: the embedded default accelerometer."
    ),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Evaluate a model's noise-free output for given inputs.

    Lists of equal length are taken element by element; a single value is
    used with every element of the others.
    """
    import numpy as np

    model = load_model(model_file)
    grids = {name: parse_grid(text, name) for name, text in
             (("--ai", ai), ("--ao", ao), ("--ap", ap))}
    lengths = {len(v) for v in grids.values()} - {1}
    if len(lengths) > 1:
        detail = ", ".join(f"{k} has {len(v)}" for k, v in grids.items())
        raise AccelcalError(
            f"input lists have different lengths ({detail}); give lists of equal length "
            "or single values"
        )
    a_i, a_o, a_p = np.broadcast_arrays(*(np.asarray(v) for v in grids.values()))
    out = np.atleast_1d(model.output(a_i, a_o, a_p))
    unit = model.output_unit
    rows = [
        {"a_i_g": float(x), "a_o_g": float(y), "a_p_g": float(z),
         f"output_{unit}": float(e), "output_g": float(e / model.K1)}
        for x, y, z, e in zip(a_i, a_o, a_p, out, strict=True)
    ]
    emit(rows, fmt, title="Model output (noise-free)")
