"""``accelcal vre``: vibration rectification error under overload and vibration (Guan2021)."""

import math
import sys
from pathlib import Path

import typer

from accelcal.cli import record_options, uncertainty_options
from accelcal.cli.common import check_format, emit, load_model, parse_grid, parse_number
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=(
        "Vibration rectification error (VRE) with asymmetry under overload + vibration "
        "(vibrafuge): predict, simulate records, reduce them, identify coefficients."
    ),
    no_args_is_help=True,
)

_MODEL_HELP = "Model file (JSON) giving the coefficients; default: the embedded accelerometer."
_FORMAT_HELP = "Output format: table, csv or json."
_OVERLOAD_HELP = (
    "Overload b along IA, g (any sign): a list 1,2,4 or a range start:stop:step (stop included)."
)
_AMPLITUDE_HELP = "Vibration amplitude A, g (>= 0): a list 5,6,7 or a range 5:10:1 (stop included)."


@app.command("table")
def table(
    *,
    model_file: Path | None = typer.Option(None, "--model", help=_MODEL_HELP),
    K2: float | None = typer.Option(None, "--K2", help="Second-order nonlinearity K2, g/g^2."),
    K3: float | None = typer.Option(None, "--K3", help="Third-order nonlinearity K3, g/g^3."),
    K4: float | None = typer.Option(None, "--K4", help="Fourth-order nonlinearity K4, g/g^4."),
    K0_asym: float | None = typer.Option(None, "--K0-asym", help="Bias asymmetry K0', g."),
    K1_asym: float | None = typer.Option(
        None, "--K1-asym", help="Scale-factor asymmetry K1', dimensionless (g/g)."
    ),
    overload: str = typer.Option("1,2,4", "--overload", help=_OVERLOAD_HELP),
    amplitude: str = typer.Option("5:10:1", "--amplitude", help=_AMPLITUDE_HELP),
    fmt: str = typer.Option("table", "--format", help=_FORMAT_HELP),
    plot: Path | None = typer.Option(
        None, "--plot", help="Directory for the figures (dU2, dU1, r vs A; PNG and SVG)."
    ),
) -> None:
    """Closed-form VRE over a grid: dU1 (eq. 9), dU2 (eq. 21), dU and r = dU2/dU (eq. 25).

    One row per (overload, amplitude) pair, overload-major. VRE in g; r is a
    fraction (nan, or null in JSON, where dU = 0). Coefficient options override --model.
    """
    from accelcal.methods.vre import vre_table

    check_format(fmt)
    overrides = {k: v for k, v in (("K2", K2), ("K3", K3), ("K4", K4), ("K0_asym", K0_asym),
                                   ("K1_asym", K1_asym)) if v is not None}
    model = load_model(model_file).replace(**overrides)
    result = vre_table(model, parse_grid(overload, "--overload"),
                       parse_grid(amplitude, "--amplitude"))
    rows = result.rows()
    if fmt == "json":
        rows = [{k: (None if math.isnan(v) else v) for k, v in r.items()} for r in rows]
    paths = []
    if plot is not None:
        from accelcal.methods.vre import table_figures
        from accelcal.plotting import save_figure

        try:
            for stem, _title, fig, _caption in table_figures(result):
                paths += save_figure(fig, plot, stem)
        except OSError as exc:
            raise AccelcalError(f"--plot {plot}: cannot write the figures ({exc})") from None
    emit(rows, fmt, title="Vibration rectification error (Guan2021 eqs. 9, 21, 23, 25)",
         headers={"overload_g": "b (g)", "amplitude_g": "A (g)", "dU1_g": "dU1 (g)",
                  "dU2_g": "dU2 (g)", "dU_g": "dU (g)", "r": "r = dU2/dU"})
    for p in paths:
        print(f"wrote {p}", file=sys.stderr)


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Record file to write (kind vibrafuge, CSV)."),
    model_file: Path | None = typer.Option(None, "--model", help=_MODEL_HELP),
    overload: str = typer.Option("1,2,4", "--overload", help=_OVERLOAD_HELP),
    amplitude: str = typer.Option("5:10:1", "--amplitude", help=_AMPLITUDE_HELP),
    direction: str = typer.Option(
        "1,0,0", "--direction",
        help="Vibration direction IA,OA,PA (unitless, normalised); the overload is along IA.",
    ),
    frequency: float = typer.Option(50.0, "--frequency", help="Vibration frequency, Hz."),
    sample_rate: float = typer.Option(5000.0, "--sample-rate", help="Sample rate, Hz."),
    duration: float = typer.Option(1.0, "--duration", help="Length of each record, s."),
    phase: float = typer.Option(0.0, "--phase", help="Vibration phase at t = 0, degrees."),
    noise: float | None = typer.Option(
        None, "--noise", help="White noise standard deviation, g; default: the model's sigma."
    ),
    quantum: float = typer.Option(
        0.0, "--quantum", help="Output quantisation step, model output unit (0: none)."
    ),
    sampling: str = typer.Option(
        "integrating", "--sampling",
        help="integrating (mean over each sample interval) or point (instantaneous).",
    ),
    seed: int = typer.Option(0, "--seed", help="Seed of the noise generator (integer)."),
    force: bool = FORCE,
) -> None:
    """Simulate static and vibrating records for every (overload, amplitude) pair."""
    import numpy as np

    from accelcal.io.formats.vibrafuge import write_vibrafuge
    from accelcal.resources import generator
    from accelcal.rigs.vibrafuge import simulate as run_sim
    from accelcal.units import DEG

    model = load_model(model_file)
    b = np.array(parse_grid(overload, "--overload"))
    a = np.array(parse_grid(amplitude, "--amplitude"))
    bb, aa = (x.ravel() for x in np.meshgrid(b, a, indexing="ij"))
    run = run_sim(
        model, bb, aa, frequency=frequency, sample_rate=sample_rate, duration=duration,
        direction=parse_grid(direction, "--direction"), phase=phase * DEG, noise=noise,
        quantum=quantum, sampling=sampling, rng=generator(seed),
    )
    write_vibrafuge(out, run, provenance={"simulated_model": model.terms(), "seed": seed})
    print(f"wrote {out}: {run.points} points x {run.static.shape[1]} samples "
          f"({sampling} sampling, noise {run.noise:g} g)", file=sys.stderr)


@app.command("reduce")
def reduce(
    files: list[Path] = typer.Argument(..., help="Vibrafuge record files (CSV)."),
    model_file: Path | None = typer.Option(
        None, "--model",
        help="Model file: adds the closed-form VRE (predicted_g, g) and z = (vre - predicted)/u.",
    ),
    fmt: str = typer.Option("table", "--format", help=_FORMAT_HELP),
) -> None:
    """Reduce records to VRE (g) with standard uncertainty, from whole-period means."""
    from accelcal.methods.vre import measure_runs

    check_format(fmt)
    m = measure_runs(files)
    rows = []
    for k in range(m["amplitude"].size):
        rows.append({"overload_g": float(m["overload"][k, 0]),
                     "overload_oa_g": float(m["overload"][k, 1]),
                     "overload_pa_g": float(m["overload"][k, 2]),
                     "amplitude_g": float(m["amplitude"][k]), "vre_g": float(m["vre"][k]),
                     "u_vre_g": float(m["uncertainty"][k])})
    if model_file is not None:
        from accelcal.model import ErrorModel

        model = ErrorModel.load(model_file)
        pred = sum(getattr(model, t) * col for t, col in m["columns"].items())
        for row, p in zip(rows, pred, strict=True):
            row["predicted_g"] = float(p)
            u = row["u_vre_g"]
            row["z"] = (row["vre_g"] - row["predicted_g"]) / u if u > 0 else None
    emit(rows, fmt, title="Measured vibration rectification error (g)")


@app.command("fit")
def fit(
    files: list[Path] = typer.Argument(..., help="Vibrafuge record files (CSV)."),
    *,
    terms: str = typer.Option(
        "K2,K3,K0_asym,K1_asym", "--terms",
        help="Coefficients to fit (comma separated), from K2, K3, K4, Koo, Kpp, Kio, Kip, "
        "Kop, K0_asym, K1_asym; units g/g^n, K0_asym in g.",
    ),
    fix: list[str] = typer.Option(
        [], "--fix", metavar="NAME=VALUE",
        help="Hold a coefficient at a known value (repeatable), same units as --terms.",
    ),
    fmt: str = typer.Option("table", "--format", help=_FORMAT_HELP),
    record_out: Path | None = typer.Option(
        None, "--record", help="Write the calibration record (JSON) of the fitted coefficients "
        "(g/g^n) to this file."),
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
    uncertainty: str = uncertainty_options.UNCERTAINTY,
    trials: int = uncertainty_options.TRIALS,
    seed: int = uncertainty_options.SEED,
    force: bool = uncertainty_options.FORCE,
    amplitude_uncertainty: float = typer.Option(
        0.0, "--amplitude-uncertainty",
        help="--uncertainty mc: relative standard uncertainty of the amplitude calibration, "
             "% (Gaussian, common to all points).",
    ),
    overload_uncertainty: float = typer.Option(
        0.0, "--overload-uncertainty",
        help="--uncertainty mc: relative standard uncertainty of the overload calibration, "
             "% (Gaussian, common to all points).",
    ),
) -> None:
    """Identify VRE coefficients by weighted least squares, with covariance.

    Reports coefficients the (b, A) design cannot separate and the
    combinations of them it does determine.
    """
    import json

    from accelcal.methods import vre
    from accelcal.outputs import describe

    check_format(fmt)
    monte_carlo = uncertainty_options.check(uncertainty, trials, seed)
    amplitude_sd = uncertainty_options.relative(
        amplitude_uncertainty, "--amplitude-uncertainty", monte_carlo)
    overload_sd = uncertainty_options.relative(
        overload_uncertainty, "--overload-uncertainty", monte_carlo)
    names = [t.strip() for t in terms.split(",")]
    if any(not t for t in names):
        raise AccelcalError(f"--terms {terms!r} has an empty name; e.g. K2,K3,K0_asym,K1_asym")
    fixed = {}
    for item in fix:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise AccelcalError(f"--fix {item!r} is not NAME=VALUE (e.g. --fix K4=0)")
        fixed[name.strip()] = parse_number(value, f"--fix {name.strip()}")
    info = record_options.lab_info_for(record_out, files, serial=serial, operator=operator)
    result = vre.reduce(files, terms=names, fixed=fixed)
    rows = result.rows()
    if monte_carlo:
        with uncertainty_options.progress_bar() as progress:
            mc = vre.uncertainty(result, trials=trials, seed=seed, amplitude_sd=amplitude_sd,
                                 overload_sd=overload_sd, progress=progress, force=force)
        p = len(mc.names)
        rows = [*uncertainty_options.merge(rows[:p], mc),
                *({**r, "mc_std": 0.0, "ci95_low": r["estimate"], "ci95_high": r["estimate"]}
                  for r in rows[p:])]
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(result.to_records(info, input_files=files), record_out):
            print(f"wrote {p}", file=sys.stderr)
    dof = result.estimate.dof
    notes = describe(result)
    if fmt == "json":
        full = result.to_dict()
        doc = {"coefficients": _json(rows), "dof": dof, "notes": notes,
               **{k: full[k] for k in ("family", "method", "combinations", "identifiability",
                                       "assumptions", "fixed")}}
        sys.stdout.write(json.dumps(doc, indent=2, allow_nan=False) + "\n")
        return
    emit(rows, fmt, title=f"VRE identification ({dof} degrees of freedom)")
    for note in notes:
        print(f"note: {note}", file=sys.stderr)


def _json(value):
    """Rows as JSON-ready values: NaN as None, also inside the ``engineering`` lists."""
    if isinstance(value, list):
        return [_json(v) for v in value]
    if isinstance(value, dict):
        return {k: _json(v) for k, v in value.items()}
    if isinstance(value, float) and math.isnan(value):
        return None
    return value
