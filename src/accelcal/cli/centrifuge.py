"""``accelcal centrifuge``: precision centrifuge tests (IEEE 836): simulate, reduce, plan."""

import sys
from pathlib import Path

import typer

from accelcal.cli import record_options
from accelcal.cli.common import check_format, emit, load_model, parse_grid, parse_number
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=("Precision centrifuge tests (IEEE 836): simulated records with the rig's errors, "
          "reduction of K2, K3, K4 and the cross-coupling (alone or jointly with a 1 g record), "
          "and test planning without data."),
    no_args_is_help=True,
)

_POSITIONS_HELP = (
    "Positions of the sensor on the arm, comma separated: IA-in, IA-out (IA radial inward/"
    "outward), OA-in, OA-out, PA-in, PA-out (OA or PA radial, IA up), IA-tan (IA tangential), "
    "or NAME=YAW/PITCH/ROLL (degrees from IA-in, about z, t, r).")
_LEVELS_HELP = "Levels Omega^2 R / g, g: a list 5,10,20 or a range 5:50:5 (stop included)."
_TERMS_HELP = ("Comma-separated model terms to estimate (K0,K1,K2,K3,K4,Ko,Kp,Koo,Kpp,Kio,Kip,"
               "Kop,K0_asym,K1_asym); default: the largest set the records separate.")
_ESTIMATE_HELP = ("Rig errors to estimate, comma separated: radius_error, arm_stretch, "
                  "proof_mass_offset, misalignment; the others are given by the file's survey.")
DEFAULT_POSITIONS = "IA-in,IA-out,OA-in,OA-out,PA-in,PA-out,IA-tan"


def _positions(text: str) -> list:
    items = [t.strip() for t in text.split(",")]
    if not text.strip() or not all(items):
        raise AccelcalError("--positions: give position names separated by commas")
    out = []
    for item in items:
        if "=" not in item:
            out.append(item)
            continue
        name, _, angles = item.partition("=")
        parts = angles.split("/")
        if len(parts) != 3:
            raise AccelcalError(f"--positions: {item[:40]!r} must be NAME=YAW/PITCH/ROLL")
        out.append({"name": name.strip(),
                    "angles_deg": [parse_number(p, "--positions") for p in parts]})
    return out


def _names(text: str | None, what: str):
    if text is None:
        return None
    items = tuple(t.strip() for t in text.split(","))
    if not all(items):
        raise AccelcalError(f"{what}: {text[:40]!r} has an empty item; give names separated by "
                            "commas")
    return items


def _small(value: float, option: str, limit: float) -> float:
    if not 0.0 <= value <= limit:
        raise AccelcalError(f"{option}: {value:g} must be between 0 and {limit:g}")
    return value


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Record file to write (kind centrifuge)."),
    model_file: Path | None = typer.Option(
        None, "--model", help="Model file; default: the embedded default accelerometer."),
    radius: float = typer.Option(1.5, "--radius", help="Nominal arm radius R0, m."),
    levels: str = typer.Option("5:50:5", "--levels", help=_LEVELS_HELP),
    positions: str = typer.Option(DEFAULT_POSITIONS, "--positions", help=_POSITIONS_HELP),
    radius_error: float = typer.Option(0.0, "--radius-error",
                                       help="True relative radius error dR/R0."),
    radius_sd: float = typer.Option(
        0.0, "--radius-sd", help="Standard uncertainty of the radius the file's survey states "
        "(relative); the reduction propagates it."),
    arm_stretch: float = typer.Option(
        0.0, "--arm-stretch", help="Arm stretch s in R = R0 (1 + s Omega^2), s^2."),
    rate_error: float = typer.Option(
        0.0, "--rate-error", help="Relative rate error: true rate = recorded x (1 + e)."),
    ripple: float = typer.Option(0.0, "--ripple",
                                 help="Once-per-revolution rate ripple, relative amplitude."),
    misalignment: float = typer.Option(
        0.0, "--misalignment", help="SD of the sensor's misalignment on the arm, rad: three "
        "angles drawn per position (the survey states this SD)."),
    tilt: float = typer.Option(0.0, "--tilt", help="Spin-axis tilt from the vertical, rad."),
    proof_mass_offset: float = typer.Option(
        0.0, "--proof-mass-offset", help="Proof-mass offset along IA, m."),
    noise: float | None = typer.Option(
        None, "--noise", help="Noise SD of one reading, output unit (default: the model's "
        "sigma x K1)."),
    readings: int = typer.Option(1, "--readings",
                                 help="Steady readings per step (each one revolution)."),
    spinup: int = typer.Option(0, "--spinup", help="Spin-up readings before each step (marked, "
                               "excluded by the reduction)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random generator."),
    force: bool = FORCE,
) -> None:
    """Write a simulated centrifuge record: one row per reading, rig and truth in its metadata."""
    import numpy as np

    from accelcal.io.formats import centrifuge as fmt_centrifuge
    from accelcal.resources import generator
    from accelcal.rigs.centrifuge import MAX_SMALL, CentrifugeRig
    from accelcal.rigs.centrifuge import simulate as simulate_rig

    model = load_model(model_file)
    specs = _positions(positions)
    lev = parse_grid(levels, "--levels")
    _small(misalignment, "--misalignment", MAX_SMALL)
    _small(radius_sd, "--radius-sd", 1.0)
    rng = generator(seed)
    names = [s if isinstance(s, str) else s["name"] for s in specs]
    drawn = {n: rng.normal(0.0, misalignment, 3) for n in names} if misalignment else {}
    rig = CentrifugeRig(radius=radius, radius_error=radius_error, arm_stretch=arm_stretch,
                        rate_error=rate_error, ripple=ripple, tilt=tilt,
                        proof_mass_offset=proof_mass_offset, misalignment=drawn)
    survey = {"radius_error": {"value": 0.0, "sd": radius_sd}} if radius_sd else {}
    if misalignment:
        survey["misalignment"] = {"value": 0.0, "sd": misalignment}
    record = simulate_rig(model, specs, np.asarray(lev), rig=rig, readings=readings,
                          spinup=spinup, noise=noise, seed=rng, survey=survey)
    meta = {**record.metadata, "local_gravity": rig.gravity,
            "simulation": {**record.metadata["simulation"], "seed": seed}}
    fmt_centrifuge.write(out, type(record)(**{**record.__dict__, "metadata": meta}))
    typer.echo(f"wrote {out}")


def _rig_rows(result) -> list[dict]:
    est = result.shared
    if est is None:
        return []
    nan = float("nan")
    covered = {"coverage_under_priors": nan} if result.type_b else {}  # the sensor rows' keys
    return [{"sensor": "rig", "coefficient": n, "estimate": float(v), "std": float(s),
             "unit": est.units.get(n, ""), "status": "fitted", "dof": int(result.dof), "plain": n,
             **covered, "eng_estimate": nan, "eng_std": nan, "eng_unit": "", "engineering": []}
            for n, v, s in zip(est.names, est.values, est.std, strict=True)]


@app.command("reduce")
def reduce(
    file: Path = typer.Argument(..., help="Centrifuge record file (kind centrifuge)."),
    *,
    one_g: Path | None = typer.Option(
        None, "--with", help="1 g record of the same sensor (tumble or dividing-head file): "
        "joint reduction, which also yields the radius error."),
    sensor: str | None = typer.Option(
        None, "--sensor", help="Sensor column of a dividing-head --with file."),
    terms: str | None = typer.Option(None, "--terms", help=_TERMS_HELP),
    estimate: str | None = typer.Option(
        None, "--estimate", help=_ESTIMATE_HELP + " Default: none alone, radius_error with "
        "--with."),
    sigma: float | None = typer.Option(
        None, "--sigma", help="Known noise SD of one reading, output unit (centrifuge alone; "
        "default: from the residuals)."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Directory for the figures (PNG and SVG)."),
    record_out: Path | None = typer.Option(
        None, "--record", help="Write a calibration record (JSON) of the sensor."),
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
) -> None:
    """Reduce a centrifuge record: estimate and standard uncertainty of each coefficient.

    Rows: the sensor's coefficients (g/g^n, K1 in output unit per g), then the
    estimated rig errors (sensor "rig"). Notes say what the records cannot separate.
    """
    from accelcal.io.formats import centrifuge as fmt_centrifuge
    from accelcal.methods import centrifuge

    check_format(fmt)
    files = [file] + ([one_g] if one_g is not None else [])
    info = record_options.lab_info_for(record_out, files, serial=serial, operator=operator)
    if record_out is not None:
        from accelcal.calibration import record_paths

        record_paths(record_out, 1)
    if sensor is not None and one_g is None:
        raise AccelcalError("--sensor goes with --with (a dividing-head record)")
    if sigma is not None and one_g is not None:
        raise AccelcalError("--sigma: a joint reduction estimates each record's noise")
    record = fmt_centrifuge.read(file)
    result = centrifuge.reduce(record, one_g=one_g, sensor=sensor, terms=_names(terms, "--terms"),
                               estimate=_names(estimate, "--estimate"), sigma=sigma)
    if plot is not None:
        result.plot(plot)
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(result.to_records(info, input_files=files), record_out):
            typer.echo(f"wrote {p}", err=True)
    emit(result.rows() + _rig_rows(result), fmt,
         title=f"{file}: {result.method} (coefficients in g/g^n, K1 in {record.output_unit}/g)")
    from accelcal.interval import statements

    stream = sys.stdout if fmt == "table" else sys.stderr
    for note in (*result.notes, *statements(result)):
        print(f"note: {note}", file=stream)


@app.command("plan")
def plan_cmd(
    *,
    levels: str = typer.Option(..., "--levels", help=_LEVELS_HELP),
    positions: str = typer.Option(..., "--positions", help=_POSITIONS_HELP),
    radius: float = typer.Option(1.5, "--radius", help="Arm radius, m."),
    noise: float = typer.Option(1e-6, "--noise", help="Noise SD of one reading, g."),
    readings: int = typer.Option(1, "--readings", help="Readings averaged per step."),
    radius_sd: float = typer.Option(0.0, "--radius-sd",
                                    help="Standard uncertainty of the radius (relative)."),
    stretch_sd: float = typer.Option(0.0, "--stretch-sd",
                                     help="Standard uncertainty of the arm stretch, s^2."),
    offset_sd: float = typer.Option(0.0, "--offset-sd",
                                    help="Standard uncertainty of the proof-mass offset, m."),
    misalignment_sd: float = typer.Option(
        0.0, "--misalignment-sd", help="Standard uncertainty of each misalignment angle, rad."),
    terms: str | None = typer.Option(None, "--terms", help=_TERMS_HELP),
    estimate: str | None = typer.Option(None, "--estimate", help=_ESTIMATE_HELP),
    one_g_positions: int = typer.Option(
        0, "--one-g-positions", help="Positions of a 1 g tumble about OA reduced jointly "
        "(0: the centrifuge alone)."),
    fmt: str = typer.Option("table", "--format", help="Output format: table or json."),
) -> None:
    """Predict the standard uncertainty of each coefficient of a test before booking the rig."""
    import json

    import numpy as np

    from accelcal.methods.centrifuge import plan

    check_format(fmt)
    if fmt == "csv":
        raise AccelcalError("--format csv: plan prints a table and notes; use table or json")
    result = plan(_positions(positions), np.asarray(parse_grid(levels, "--levels")),
                  noise_sd=noise, readings=readings, radius=radius,
                  terms=_names(terms, "--terms"), radius_sd=radius_sd, stretch_sd=stretch_sd,
                  offset_sd=offset_sd, misalignment_sd=misalignment_sd,
                  estimate=_names(estimate, "--estimate") or (),
                  one_g_positions=one_g_positions)
    statements = list(result.identifiability.statements())
    if fmt == "json":
        typer.echo(json.dumps({"terms": list(result.terms), "estimated": list(result.estimated),
                               "predicted": result.rows(), "statements": statements},
                              indent=2, allow_nan=False))
        return
    emit(result.rows(), fmt, title="Predicted standard uncertainties (1 sigma)")
    for s in statements:
        typer.echo(f"note: {s}")
