"""``accelcal dividing-head``: simulate, reduce and study indexing-head calibrations."""

import re
from pathlib import Path

import typer

from accelcal.cli import record_options, uncertainty_options
from accelcal.cli.common import check_format, emit, parse_grid, parse_number
from accelcal.cli.input_options import GAPS, MAX_FILL, print_reduction_repairs
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError
from accelcal.validation import shown, shown_name

app = typer.Typer(
    help=(
        "Accelerometers on an indexing (dividing) head: simulate records, reduce them "
        "(single-sensor, four-sensor separation, joint least squares, IEEE tumble), and "
        "compare the methods by Monte Carlo (Dong2014, corrected)."
    ),
    no_args_is_help=True,
)

_ANGLE_UNITS = {"arcsec": "ARCSEC", "as": "ARCSEC", "urad": 1e-6, "mrad": 1e-3, "rad": 1.0,
                "deg": "DEG"}
_HARMONIC = re.compile(r"^\s*(\d+)\s*([cs])\s*=\s*(.+)$")

_POSITIONS = typer.Option(
    24, "--positions",
    help="Number of equally spaced head positions (>= 6; method four: >= 12). A size that "
         "cannot fit in memory is refused with the memory it would need.")
_MOUNTS = typer.Option(
    "0,90,180,270", "--mounts", help="Mount phase of each sensor, deg (comma separated)."
)
_ANGLE_ERROR = typer.Option(
    "uniform:2arcsec", "--angle-error",
    help=(
        "Head angular position error: uniform:X (random within +-X, e.g. uniform:2arcsec), "
        "harmonics:2c=5arcsec,3s=1arcsec (Fourier terms m c|s = amplitude), "
        "values:0.8,-1.2,... (one per position), file:PATH (one value per position, arcsec, "
        "separated by commas, spaces or lines; # starts a comment, e.g. a head survey) or "
        "none. Units arcsec, urad, mrad, rad or deg (default arcsec); at most 1 deg (an "
        "indexing head's error is a few arcsec)."
    ),
)
_FIRST_HARMONIC = typer.Option(
    "0,0", "--first-harmonic",
    help="First harmonic C,S of the head error added to the profile, rad (or with a unit "
         "suffix, e.g. 3arcsec,0). Dong2014 measured 1.50e-5,-1.9e-6.",
)
_NOISE = typer.Option(
    2.8e-6, "--noise", help="Output noise standard deviation, V (Dong2014 Table 1: 2.8e-6 V)."
)
_SEED = typer.Option(0, "--seed", help="Random seed (integer >= 0).")
_ETA = typer.Option(
    None, "--eta", help="Mounting misalignment of each sensor, arcsec (comma separated; default 0)."
)
_MODELS = typer.Option(
    None, "--model",
    help="Model file (JSON) of a sensor; repeat once per sensor. Default: Dong2014 Table 1 "
         "coefficients (volts).",
)
_REPEATS = typer.Option(1, "--repeats", help="Readings per position.")


def _angle(text: str, what: str, default_unit: str) -> float:
    """A number with an optional angle unit suffix, in rad."""
    from accelcal import units

    match = re.match(r"^\s*(.*?)\s*([a-z]*)\s*$", text)
    number, unit = match.groups() if match else (text, "")
    unit = unit or default_unit
    if unit not in _ANGLE_UNITS:
        raise AccelcalError(
            f"{what}: unknown angle unit {shown(unit)} in {shown(text)}; use "
            f"{', '.join(_ANGLE_UNITS)}"
        )
    factor = _ANGLE_UNITS[unit]
    factor = getattr(units, factor) if isinstance(factor, str) else factor
    return parse_number(number, what) * factor


def parse_angle_error(text: str):
    """Parse ``--angle-error`` into an AngleErrorProfile."""
    from accelcal.rigs.dividing_head import AngleErrorProfile

    kind, _, rest = text.partition(":")
    kind = kind.strip()
    if kind == "none" and not rest.strip():
        return AngleErrorProfile()
    if kind == "uniform" and rest.strip():
        return AngleErrorProfile.uniform(_angle(rest, "--angle-error uniform", "arcsec"))
    if kind == "harmonics" and rest.strip():
        terms = {}
        for item in rest.split(","):
            m = _HARMONIC.match(item)
            if not m:
                raise AccelcalError(
                    f"--angle-error: harmonic {shown(item.strip())} is not like 2c=5arcsec"
                )
            key = (int(m.group(1)), m.group(2))
            if key in terms:
                raise AccelcalError(f"--angle-error: harmonic {shown(item.strip())} given twice")
            terms[key] = _angle(m.group(3), f"--angle-error {shown_name(item.strip())}", "arcsec")
        return AngleErrorProfile.harmonics(terms)
    if kind == "values" and rest.strip():
        return AngleErrorProfile.values(
            [_angle(v, "--angle-error values", "arcsec") for v in rest.split(",")])
    if kind == "file" and rest.strip():
        return AngleErrorProfile.values(_angle_error_file(Path(rest.strip())))
    raise AccelcalError(
        f"--angle-error {shown(text)} is not uniform:X, harmonics:2c=A,3s=B, values:A,B,..., "
        "file:PATH or none"
    )


def _angle_error_file(path: Path) -> list[float]:
    """Angle errors in arcsec from a text file, in rad (``--angle-error file:PATH``)."""
    from accelcal.io.limits import MAX_JSON_BYTES, read_bounded
    from accelcal.units import ARCSEC

    # one value per position, all of which go into the record's metadata line
    try:
        text = read_bounded(path, MAX_JSON_BYTES, "--angle-error file").decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror or exc if isinstance(exc, OSError) else "not UTF-8 text"
        raise AccelcalError(f"--angle-error file {path}: cannot read it ({reason})") from None
    values = []
    for number, line in enumerate(text.splitlines(), start=1):
        for item in line.split("#", 1)[0].replace(",", " ").split():
            values.append(parse_number(item, f"{path}, line {number}") * ARCSEC)
    if not values:
        raise AccelcalError(f"--angle-error file {path} holds no values; give one per position "
                            "in arcsec")
    return values


def _pair(text: str, what: str) -> tuple[float, float]:
    items = text.split(",")
    if len(items) != 2:
        raise AccelcalError(f"{what}: {shown(text)} must be two values C,S")
    return (_angle(items[0], what, "rad"), _angle(items[1], what, "rad"))


def _rig(*, positions, mounts, angle_error, first_harmonic, noise, eta, models, repeats):
    import numpy as np

    from accelcal.model import ErrorModel
    from accelcal.rigs.dividing_head import DividingHeadRig, dong2014_models
    from accelcal.units import ARCSEC, DEG

    phases = np.array(parse_grid(mounts, "--mounts")) * DEG
    if models and len(models) != phases.size:
        raise AccelcalError(
            f"{len(models)} --model files for {phases.size} --mounts; give one each"
        )
    if models:
        sensor_models = tuple(ErrorModel.load(p) for p in models)
    else:
        sensor_models = dong2014_models(phases.size)
    eta_rad = None if eta is None else np.array(parse_grid(eta, "--eta")) * ARCSEC
    return DividingHeadRig.uniform(
        positions, sensor_models, mounts=phases, eta=eta_rad,
        angle_error=parse_angle_error(angle_error),
        first_harmonic=_pair(first_harmonic, "--first-harmonic"), noise=noise, repeats=repeats,
    )


@app.command("simulate")
@forced
def simulate_cmd(
    *,
    out: Path = typer.Option(..., "--out", help="Record file to write (CSV with JSON metadata)."),
    positions: int = _POSITIONS,
    mounts: str = _MOUNTS,
    angle_error: str = _ANGLE_ERROR,
    first_harmonic: str = _FIRST_HARMONIC,
    noise: float = _NOISE,
    seed: int = _SEED,
    eta: str | None = _ETA,
    model: list[Path] | None = _MODELS,
    repeats: int = _REPEATS,
    autocollimator_sd: float | None = typer.Option(
        None, "--autocollimator-sd",
        help="Also record simulated autocollimator readings of the head error with this "
             "standard deviation, arcsec.",
    ),
    force: bool = FORCE,
) -> None:
    """Simulate an indexing-head record; the truth is kept in its metadata."""
    import json

    from accelcal.io.formats.dividing_head import (
        MAX_ANGLE_ERROR_RAD,
        check_record_size,
        write_head_record,
    )
    from accelcal.resources import generator
    from accelcal.rigs.dividing_head import simulate
    from accelcal.units import ARCSEC

    rng = generator(seed)
    if autocollimator_sd is not None and not (
            0 < autocollimator_sd * ARCSEC <= MAX_ANGLE_ERROR_RAD):
        raise AccelcalError("--autocollimator-sd must be a positive number of arcsec, at most "
                            "3600 (1 deg)")
    rig = _rig(positions=positions, mounts=mounts, angle_error=angle_error,
               first_harmonic=first_harmonic, noise=noise, eta=eta, models=model,
               repeats=repeats)
    # the simulated head errors (and readings) go into the metadata: the file must load
    check_record_size(rig.positions.size, rig.n_sensors, rig.repeats,
                      per_position=1 + (autocollimator_sd is not None))
    run = simulate(rig, rng)
    ac = ac_sd = None
    if autocollimator_sd is not None:
        ac_sd = autocollimator_sd * ARCSEC
        ac = run.d_alpha + ac_sd * rng.standard_normal(run.d_alpha.shape)
    simulation = {
        "models": [json.loads(m.to_json()) for m in rig.models],
        "eta_rad": rig.eta.tolist(),
        "angle_error_rad": run.d_alpha.tolist(),
        "seed": seed,
        "description": f"angle error {angle_error}, first harmonic {first_harmonic} rad, "
                       f"noise {noise} V",
    }
    write_head_record(
        out, rig.positions, run.outputs, rig.mounts, output_unit=rig.models[0].output_unit,
        nominal_scale_factors=[m.K1 for m in rig.models], autocollimator=ac,
        autocollimator_sd=ac_sd, simulation=simulation, lab={"simulated": True},
    )
    typer.echo(f"wrote {out}")


@app.command("reduce")
def reduce_cmd(
    file: Path = typer.Argument(..., help="dividing-head record file."),
    *,
    method: str = typer.Option(
        "joint", "--method", help="Reduction: single, four, joint or tumble."
    ),
    first_harmonic: str | None = typer.Option(
        None, "--first-harmonic",
        help="Known first harmonic C,S of the head error, rad (or with a unit suffix). "
             "Default: the file's measured value, else unknown (taken as zero).",
    ),
    first_harmonic_sd: float | None = typer.Option(
        None, "--first-harmonic-sd",
        help="Standard uncertainty of the first harmonic, rad (or, when it is unknown, a "
             "systematic bound to include in the uncertainty).",
    ),
    covariance: str | None = typer.Option(
        None, "--covariance",
        help="four: 'propagated' (default: the readings' noise propagated exactly through "
             "every step) or 'paper' (Dong2014 eq. (31), each sensor's residual variance; "
             "optimistic: it omits the noise carried in by the separated head error, SDs "
             "1.3-1.9x too small, 95 % coverage 0.65-0.87).",
    ),
    gauss_newton: bool = typer.Option(
        False, "--gauss-newton",
        help="joint: iterate on the exact (non-linearised) model (with the file's "
             "autocollimator readings, if any, as pseudo-observations).",
    ),
    priors: str = typer.Option(
        "default", "--priors",
        help="Priors of the terms Dong2014 eq. (5) leaves out (K3, K0', K1', and K0'/2 of "
             "unknown sign where a_i = 0): default (twice the embedded default "
             "accelerometer's magnitude, rectangular), propagated as Type B; none (state only "
             "how much each would move each row).",
    ),
    sensor_terms: str = typer.Option(
        "independent", "--sensor-terms",
        help="How the sensors' priors are correlated: independent (default: separate "
             "instruments, GUM 5.2; the signs of K0'/2 where a_i = 0 independent too) or equal "
             "(each row also bounded with every sensor's terms equal, in the worst sign: "
             "sensors sharing a design bias; conservative otherwise).",
    ),
    gaps: str = GAPS, max_fill: int = MAX_FILL,
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Directory for figures (residuals, separated head error; PNG+SVG)."
    ),
    record_out: Path | None = typer.Option(
        None, "--record", help="Write one calibration record (JSON) per sensor: FILE with -1, "
        "-2, ... inserted before the suffix, in sensor column order (one sensor: FILE).",
    ),
    serial: str | None = record_options.SERIALS,
    operator: str | None = record_options.OPERATOR,
    uncertainty: str = uncertainty_options.UNCERTAINTY,
    trials: int = uncertainty_options.TRIALS,
    seed: int = uncertainty_options.SEED,
    force: bool = uncertainty_options.FORCE,
    angle_error_level: str | None = typer.Option(
        None, "--angle-error-level",
        help="--uncertainty mc: bound of the head's angle error at each position (rectangular "
             "Type-B input), arcsec or with a unit suffix (e.g. 2arcsec, 10urad).",
    ),
) -> None:
    """Reduce a record: estimate and standard uncertainty of each coefficient (volts)."""
    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.io.recordings.repairs import with_repairs
    from accelcal.methods.dividing_head import HeadData, lab_options, reduce

    check_format(fmt)
    monte_carlo = uncertainty_options.check(uncertainty, trials, seed)
    level = 0.0 if angle_error_level is None else _angle(
        angle_error_level, "--angle-error-level", "arcsec")
    if angle_error_level is not None and not monte_carlo:
        raise AccelcalError("--angle-error-level is a bound used with --uncertainty mc")
    record = read_head_record(file, gaps=gaps, max_fill=max_fill)
    data = HeadData.from_record(record)
    info = record_options.lab_info_for(record_out, [file], serial=serial, operator=operator,
                                       sensors=len(record.sensors))
    if record_out is not None:  # refused before the reduction, not after it
        from accelcal.calibration import record_paths

        record_paths(record_out, len(record.sensors))
    options = lab_options(  # the file's first harmonic and readings, unless given
        record, method, covariance=covariance, gauss_newton=gauss_newton or None,
        first_harmonic=None if first_harmonic is None else _pair(first_harmonic,
                                                                 "--first-harmonic"),
        first_harmonic_sd=first_harmonic_sd)
    result = with_repairs(reduce(data, method, priors=priors, sensor_terms=sensor_terms, **options),
                          record.repairs)
    print_reduction_repairs(result)
    rows = result.rows()
    if monte_carlo:
        from accelcal.methods.dividing_head import head_uncertainty

        with uncertainty_options.progress_bar() as progress:
            mc = head_uncertainty(
                data, result, trials=trials, seed=seed, angle_error_level=level,
                first_harmonic=options.get("first_harmonic"),
                first_harmonic_sd=options.get("first_harmonic_sd", 0.0),
                autocollimator_sd=options.get("autocollimator_sd"), progress=progress,
                force=force)
        rows = uncertainty_options.merge(rows, mc)
    if plot is not None:
        result.plot(plot, truth=_true_angle_error(record))
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(result.to_records(info, input_files=[file]), record_out):
            typer.echo(f"wrote {p}", err=True)
    emit(rows, fmt,
         title=f"{file}: method {method} (coefficients in {record.output_unit}, "
               f"{record.output_unit}/g, {record.output_unit}/g^2)")
    from accelcal.interval import statements

    for note in statements(result):  # where a 95 % interval covers outside 93-97 %
        typer.echo(f"note: {note}", err=fmt != "table")


def _true_angle_error(record):
    import numpy as np

    if record.simulation and "angle_error_rad" in record.simulation:
        return np.asarray(record.simulation["angle_error_rad"], dtype=float)
    return None


@app.command("study")
def study_cmd(
    *,
    trials: int | None = typer.Option(
        None, "--trials", help="Number of Monte Carlo trials (>= 2; required unless --exact). "
        "Trials stream in blocks: memory stays bounded for any count, and a huge count is a "
        "long run with a progress bar."),
    exact: bool = typer.Option(
        False, "--exact", help="No sampling: the RMS errors and mean formal SDs a Monte Carlo "
        "study converges to, in closed form (linearised methods; formal SDs for Gaussian "
        "inputs, uniform head errors by their variance). Instant."),
    positions: int = _POSITIONS,
    mounts: str = _MOUNTS,
    angle_error: str = _ANGLE_ERROR,
    first_harmonic: str = _FIRST_HARMONIC,
    noise: float = _NOISE,
    seed: int = _SEED,
    eta: str | None = _ETA,
    model: list[Path] | None = _MODELS,
    repeats: int = _REPEATS,
    h1_sd: float = typer.Option(
        0.0, "--h1-sd",
        help="SD of the first-harmonic measurement given to the known-h1 methods, rad "
             "(Dong2014: 5e-7).",
    ),
    per_sensor: bool = typer.Option(False, "--per-sensor", help="One row per sensor too."),
    chunk: int | None = typer.Option(
        None, "--chunk",
        help="Trials per task (rounded up to whole seed blocks of 32768 trials; default one "
             "block): scheduling granularity only, the result does not change.",
    ),
    workers: int | None = typer.Option(
        None, "--workers",
        help="Run on a local Dask cluster of this many worker processes (needs the dask "
             "extra of accelcal).",
    ),
    scheduler: str | None = typer.Option(
        None, "--scheduler",
        help="Run on an existing Dask scheduler, e.g. tcp://host:8786 (needs the dask "
             "extra of accelcal).",
    ),
    timeout: float = typer.Option(
        10.0, "--timeout", help="Seconds to wait for --scheduler to answer before giving up, s."
    ),
    force: bool = typer.Option(
        False, "--force", help="Run a study estimated to take more than an hour (its first "
        "task is timed; refused otherwise, with the estimate)."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Monte Carlo: RMS actual error and mean formal SD per method and coefficient (volts).

    The result depends only on the options describing the study and --seed: it is
    bit-identical with or without --workers or --scheduler and for any --chunk.
    """
    from accelcal.cli.progress import DelayedProgress
    from accelcal.methods.dividing_head import run_study

    check_format(fmt)
    if exact and (trials is not None or workers is not None or scheduler is not None
                  or chunk is not None):
        raise AccelcalError("--exact draws no trials; leave out --trials, --chunk, --workers "
                            "and --scheduler", parameter="exact")
    if not exact and trials is None:
        raise AccelcalError("give the number of Monte Carlo trials, or --exact",
                            parameter="trials")
    rig = _rig(positions=positions, mounts=mounts, angle_error=angle_error,
               first_harmonic=first_harmonic, noise=noise, eta=eta, models=model,
               repeats=repeats)
    if exact:
        from accelcal.methods.dividing_head.exact import exact_study

        result = exact_study(rig, h1_sd=h1_sd)
        what = "exact (no sampling)"
    else:
        with DelayedProgress("Monte Carlo trials") as progress:
            result = run_study(rig, trials, seed, h1_sd=h1_sd, chunk=chunk, workers=workers,
                               scheduler=scheduler, timeout=timeout, progress=progress,
                               force=force)
        what = f"{trials} trials"
    for note in result.notes:
        typer.echo(f"accelcal: note: {note}", err=True)
    emit(result.rows(per_sensor=per_sensor), fmt,
         title=f"{what}: RMS actual error and mean formal SD "
               "(averaged over sensors; K_O compared with K_O* = K_O + K_I (eta + d0))")
