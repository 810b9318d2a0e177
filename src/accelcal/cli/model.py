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
_TEMPERATURE_NAMES = "K0_Tk, K1_Tk, K2_Tk, Ko_Tk, Kp_Tk (k = 1, 2, 3)"


def _temperature_rows(model) -> list[dict]:
    """Rows of a model's temperature terms (none without them)."""
    from accelcal.terms import TEMPERATURE_TERMS

    tt = model.temperature
    if tt is None:
        return []
    rows = [{"term": "T0", "value": tt.reference, "unit": "degC",
             "description": "reference temperature of the temperature polynomials"}]
    if tt.valid_range is not None:
        rows += [{"term": name, "value": value, "unit": "degC", "description": what}
                 for name, value, what in zip(("T_min", "T_max"), tt.valid_range,
                                              ("lowest valid temperature",
                                               "highest valid temperature"), strict=True)]
    return rows + [{"term": name, "value": value, "unit": TEMPERATURE_TERMS[name].unit,
                    "description": TEMPERATURE_TERMS[name].description}
                   for name, value in tt.coefficients]


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
    ] + _temperature_rows(model)
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
            f"Set a term (repeatable). NAME is one of {_TERM_NAMES}; or a temperature "
            f"coefficient {_TEMPERATURE_NAMES} with T0, the reference temperature in degC "
            "(default 25). Units: K1 in output unit per g, sigma in g, others in g/g^n; "
            "temperature coefficients per degC^k, K1's relative (1e-6/degC = 1 ppm/degC). "
            "Terms not set are 0, except K1 = 1."
        ),
    ),
    output_unit: str = typer.Option(
        "V", "--output-unit", help="Output unit of the model: V, mV, mA or g."
    ),
) -> None:
    """Write a new model file from NAME=VALUE settings."""
    from accelcal.cli.common import parse_number
    from accelcal.model import ErrorModel
    from accelcal.validation import shown, shown_name

    terms: dict[str, float] = {}
    for item in set_:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise AccelcalError(f"--set {shown(item)} is not NAME=VALUE (e.g. --set K2=7.87e-6)")
        if name in terms:
            raise AccelcalError(f"--set gives {shown_name(name)} twice; give each term once")
        terms[name] = parse_number(value, f"--set {shown_name(name)}")
    from accelcal.terms import TEMPERATURE_TERMS, TERMS, TemperatureTerms, unknown_term

    reference = terms.pop("T0", None)
    thermal = {n: terms.pop(n) for n in list(terms) if n in TEMPERATURE_TERMS}
    unknown = [n for n in terms if n not in TERMS]
    if unknown:
        raise AccelcalError(unknown_term(unknown[0], [*TERMS, "T0", *TEMPERATURE_TERMS]))
    model = ErrorModel.from_terms(terms, output_unit=output_unit)
    if thermal or reference is not None:
        model = model.replace(temperature=TemperatureTerms(
            25.0 if reference is None else reference, thermal))
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
    *,
    temperature: str | None = typer.Option(
        None, "--temperature",
        help="Sensor temperature, degC (number, list or range): the model's temperature terms "
             "are evaluated there (default: the model's own coefficients, those at T0)."),
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
    given = [("--ai", ai), ("--ao", ao), ("--ap", ap)]
    if temperature is not None:
        given.append(("--temperature", temperature))
    grids = {name: parse_grid(text, name) for name, text in given}
    lengths = {len(v) for v in grids.values()} - {1}
    if len(lengths) > 1:
        detail = ", ".join(f"{k} has {len(v)}" for k, v in grids.items())
        raise AccelcalError(
            f"input lists have different lengths ({detail}); give lists of equal length "
            "or single values"
        )
    a_i, a_o, a_p, *temp = np.broadcast_arrays(*(np.asarray(v) for v in grids.values()))
    unit = model.output_unit
    if not temp:
        out = np.atleast_1d(model.output(a_i, a_o, a_p))
        rows = [
            {"a_i_g": float(x), "a_o_g": float(y), "a_p_g": float(z),
             f"output_{unit}": float(e), "output_g": float(e / model.K1)}
            for x, y, z, e in zip(a_i, a_o, a_p, out, strict=True)
        ]
        emit(rows, fmt, title="Model output (noise-free)")
        return
    t = temp[0]
    out = np.atleast_1d(model.output(a_i, a_o, a_p, temperature=t))
    out_g = np.atleast_1d(model.output_g(a_i, a_o, a_p, temperature=t))
    rows = [{"a_i_g": float(x), "a_o_g": float(y), "a_p_g": float(z), "temperature_degC": float(c),
             f"output_{unit}": float(e), "output_g": float(g)}
            for x, y, z, c, e, g in zip(a_i, a_o, a_p, t, out, out_g, strict=True)]
    emit(rows, fmt, title="Model output (noise-free; output_g = E / K1(T))")
