"""``accelcal transverse``: transverse sensitivity on a shaker (GuanTang, ISO 16063-31)."""

import sys
from pathlib import Path

import typer

from accelcal.cli import record_options, uncertainty_options
from accelcal.cli.common import check_format, emit, load_model, parse_grid
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=(
        "Transverse sensitivity of an accelerometer vibrated in its transverse plane on a "
        "shaker (GuanTang, after ISO 16063-31): sweep, simulate records, analyze, fit."
    ),
    no_args_is_help=True,
)

_EST_HELP = (
    "Amplitude estimator: peak (max |u| over whole periods / A_v, the paper's eqs. (21)-(22)), "
    "half-p2p ((max - min)/2 / A_v) or fundamental (w component by sine fit / reference "
    "amplitude, ISO practice)."
)
_AXIAL_HELP = (
    "Axial sensitivity for sT_rel: eq20 (output at +1 g, GuanTang eq. (20)) or symmetric "
    "((u(+1 g) - u(-1 g))/2)."
)
_MODEL_HELP = "Model file (JSON); default: the embedded default accelerometer."
_PAPER_HELP = (
    "Use the plausible parameter set of GuanTang Fig. 4 (s_I = 1000.055 mV/g) instead of --model."
)
_LINEAR_HELP = (
    "Use the linear vibration-accelerometer model instead: 's_i,s_o,s_p' in mV per g."
)


def _sensor(model_file, paper: bool, linear: str | None):
    from accelcal.methods.transverse import GUANTANG_FIG4
    from accelcal.rigs.shaker import LinearModel

    chosen = sum([model_file is not None, paper, linear is not None])
    if chosen > 1:
        raise AccelcalError("give only one of --model, --paper and --linear")
    if paper:
        return GUANTANG_FIG4
    if linear is not None:
        values = parse_grid(linear, "--linear")
        if len(values) != 3:
            raise AccelcalError("--linear needs three sensitivities 's_i,s_o,s_p' in mV/g")
        return LinearModel(*values, output_unit="mV")
    return load_model(model_file)


def _angles(text: str, minimum: int = 1):
    from accelcal.methods.transverse import check_angles

    return check_angles(parse_grid(text, "--angles"), minimum=minimum)


def _amplitudes(text: str) -> list[float]:
    values = parse_grid(text, "--amplitude")
    bad = [v for v in values if not v > 0]
    if bad:
        raise AccelcalError(f"--amplitude: {bad[0]:g} g is not positive; give amplitudes > 0 g")
    return values


def _output(sweeps, fmt: str, summary: bool, title: str) -> None:
    rows = [r for sw in sweeps for r in (
        [sw.summary()] if summary else sw.rows())]
    emit(rows, fmt, title=title)


def _plot(sweeps, directory, linear=None, stem="transverse_polar") -> None:
    from accelcal.methods.transverse import save_polar

    paths = save_polar(sweeps, directory, linear=linear, stem=stem,
                       title=f"Transverse sensitivity ({sweeps[0].estimator})")
    for p in paths:
        print(f"wrote {p}", file=sys.stderr)


@app.command("sweep")
def sweep_cmd(
    *,
    model_file: Path | None = typer.Option(None, "--model", help=_MODEL_HELP),
    paper: bool = typer.Option(False, "--paper", help=_PAPER_HELP),
    linear: str | None = typer.Option(None, "--linear", help=_LINEAR_HELP),
    amplitude: str = typer.Option(
        "1,5,20,50", "--amplitude", help="Vibration amplitudes A_v, g (list or range)."),
    angles: str = typer.Option(
        "0:355:5", "--angles", help="Direction angles, deg from PA towards OA (list or range), "
        "within one turn."),
    estimator: str = typer.Option("fundamental", "--estimator", help=_EST_HELP),
    gravity: float = typer.Option(
        0.0, "--gravity", help="Static gravity along the vibration axis, g (0 idealised, 1 "
        "vertical shaker with IA horizontal)."),
    axial: str = typer.Option("eq20", "--axial", help=_AXIAL_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    summary: bool = typer.Option(
        False, "--summary", help="Print S_Tmax, theta_max, S_Tmin, theta_min (deg) and the "
        "number of local maxima per amplitude instead of every angle."),
    plot: Path | None = typer.Option(
        None, "--plot", help="Directory for polar plots (PNG and SVG), with the linear model's "
        "figure of eight beside them."),
    frequency: float = typer.Option(160.0, "--frequency", help="Vibration frequency, Hz."),
    sample_rate: float = typer.Option(10240.0, "--sample-rate", help="Sample rate, Hz."),
    periods: float = typer.Option(4.0, "--periods", help="Record length, periods."),
    noise: float = typer.Option(0.0, "--noise", help="Sensor output noise, g (std)."),
    seed: int | None = typer.Option(None, "--seed", help="Seed of the noise generator."),
) -> None:
    """Simulate the shaker test over angles and amplitudes; print sT per angle.

    CSV/JSON keys: amplitude_g, angle_deg, sT (output unit per g), sT_rel (fraction).
    """
    from accelcal.methods.transverse import axial_sensitivity, sweep
    from accelcal.resources import generator
    from accelcal.rigs.shaker import LinearModel

    check_format(fmt)
    sensor = _sensor(model_file, paper, linear)
    theta = _angles(angles)
    amps = _amplitudes(amplitude)
    rng = generator(seed)  # checked even when no noise is drawn
    rng = rng if noise > 0 else None
    rig = {"frequency": frequency, "sample_rate": sample_rate, "periods": periods,
           "noise": noise}
    sweeps = sweep(sensor, amps, theta, estimator, gravity=gravity, axial=axial, rng=rng, **rig)
    lin = None
    if plot is not None:
        if isinstance(sensor, LinearModel):
            lin_model = sensor
        else:
            lin_model = LinearModel(s_i=axial_sensitivity(sensor, axial),
                                    s_o=sensor.K1 * sensor.Ko, s_p=sensor.K1 * sensor.Kp,
                                    output_unit=sensor.output_unit)
        lin = sweep(lin_model, amps[:1], theta, estimator, axial=axial, **rig)[0]
    _output(sweeps, fmt, summary, f"Transverse sensitivity ({estimator}, {sensor.output_unit}/g)")
    if plot is not None:
        _plot(sweeps, plot, linear=lin)


@app.command("simulate")
def simulate_cmd(
    *,
    out: Path = typer.Option(..., "--out", help="Directory for the record files (one per angle "
                             "and amplitude), or one FILE.csv for a single record."),
    model_file: Path | None = typer.Option(None, "--model", help=_MODEL_HELP),
    paper: bool = typer.Option(False, "--paper", help=_PAPER_HELP),
    linear: str | None = typer.Option(None, "--linear", help=_LINEAR_HELP),
    amplitude: str = typer.Option("5", "--amplitude", help="Vibration amplitudes A_v, g."),
    angles: str = typer.Option("0:330:30", "--angles", help="Direction angles, deg."),
    frequency: float = typer.Option(160.0, "--frequency", help="Vibration frequency, Hz."),
    sample_rate: float = typer.Option(10240.0, "--sample-rate", help="Sample rate, Hz."),
    periods: float = typer.Option(
        16.0, "--periods", help="Record length in periods (non-integer: partial period)."),
    phase: float = typer.Option(0.0, "--phase", help="Initial phase of the vibration, deg."),
    gravity: float = typer.Option(
        0.0, "--gravity", help="Static gravity along the vibration axis, g."),
    transverse_ratio: float = typer.Option(
        0.0, "--transverse-ratio", help="Shaker's own transverse motion / A_v (fraction)."),
    transverse_phase: float = typer.Option(
        0.0, "--transverse-phase", help="Its phase relative to the vibration, deg."),
    transverse_direction: float = typer.Option(
        0.0, "--transverse-direction", help="Its direction, deg, from the in-plane normal to the "
        "vibration axis towards IA."),
    measure_transverse: bool = typer.Option(
        False, "--measure-transverse", help="Record reference channels ref_n and ref_ia of the "
        "shaker's transverse motion."),
    rest: bool = typer.Option(
        False, "--rest", help="Also record the output at rest (column u_rest) for the DC shift."),
    noise: float | None = typer.Option(
        None, "--noise", help="Sensor output noise, g (std); default the model's sigma."),
    ref_noise: float = typer.Option(0.0, "--ref-noise", help="Reference channel noise, g (std)."),
    seed: int | None = typer.Option(None, "--seed", help="Seed of the noise generator."),
) -> None:
    """Simulate shaker records and write them as 'shaker' record files."""
    import numpy as np

    from accelcal.io.formats.shaker import write_records
    from accelcal.methods.transverse import axial_sensitivity
    from accelcal.resources import generator
    from accelcal.rigs.shaker import ShakerRig

    sensor = _sensor(model_file, paper, linear)
    theta = _angles(angles)
    amps = _amplitudes(amplitude)
    rng = generator(seed)
    records = [
        ShakerRig(amplitude=a, frequency=frequency, sample_rate=sample_rate, periods=periods,
                  phase=np.deg2rad(phase), gravity=gravity, transverse_ratio=transverse_ratio,
                  transverse_phase=np.deg2rad(transverse_phase),
                  transverse_direction=np.deg2rad(transverse_direction), ref_noise=ref_noise,
                  noise=noise, measure_transverse=measure_transverse, rest=rest,
                  ).simulate(sensor, theta, rng=rng)
        for a in amps
    ]
    extra = {"axial_sensitivity": {d: axial_sensitivity(sensor, d) for d in ("eq20", "symmetric")},
             "source": "accelcal transverse simulate"}
    paths = write_records(records, out, extra=extra)
    typer.echo(f"wrote {len(paths)} record file(s) to {out}")


def _read(data: Path):
    from accelcal.io.formats.shaker import read_records

    return read_records(data)


@app.command("analyze")
def analyze_cmd(
    data: Path = typer.Argument(..., help="Directory of shaker record files, or one file."),
    *,
    estimator: str = typer.Option("fundamental", "--estimator", help=_EST_HELP),
    axial: str = typer.Option("eq20", "--axial", help=_AXIAL_HELP),
    axial_sensitivity: float | None = typer.Option(
        None, "--axial-sensitivity", help="Axial sensitivity s_I, output unit per g (default: "
        "the records' metadata for --axial)."),
    no_separate: bool = typer.Option(
        False, "--no-separate", help="Do not subtract the shaker's measured motion along IA."),
    fit_frequency: bool = typer.Option(
        False, "--fit-frequency", help="Fit the vibration frequency (Hz) to the reference "
        "channel (IEEE 1057 four-parameter fit) instead of trusting frequency_hz."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    summary: bool = typer.Option(False, "--summary", help="Print extremes per amplitude."),
    plot: Path | None = typer.Option(None, "--plot", help="Directory for polar plots."),
) -> None:
    """Transverse sensitivity from records: sT per angle (amplitude_g, angle_deg, sT, sT_rel)."""
    from accelcal.methods.transverse import (
        estimate_sT,
        records_axial_sensitivity,
        with_fitted_frequency,
    )

    check_format(fmt)
    sweeps = []
    for rec in _read(data):
        if fit_frequency:
            rec = with_fitted_frequency(rec)  # noqa: PLW2901
        s_I = axial_sensitivity
        if s_I is None:
            s_I = records_axial_sensitivity(rec, axial)
        if s_I is None:
            raise AccelcalError(
                f"{data}: the records give no axial sensitivity ({axial}); pass "
                "--axial-sensitivity in the output unit per g")
        sweeps.append(estimate_sT(rec, estimator, s_I=float(s_I), axial=axial,
                                  separate=not no_separate))
    _output(sweeps, fmt, summary, f"Transverse sensitivity ({estimator})")
    if plot is not None:
        _plot(sweeps, plot)


@app.command("fit")
def fit_cmd(
    data: Path = typer.Argument(..., help="Directory of shaker record files (3 or more angles)."),
    *,
    route: str = typer.Option(
        "2w", "--route", help="Components used besides the w phasor: 2w (2w phasor), dc (DC "
        "shift from rest, needs u_rest), both, or w (w only; k_oo.. need gravity)."),
    terms: str = typer.Option(
        "Ko,Kp,Koo,Kpp,Kop", "--terms", help="Terms to fit (Ko, Kp in g/g; Koo, Kpp, Kop, "
        "Kio, Kip, K2 in g/g^2; K0, K0_asym in g; K1_asym in g/g)."),
    scale_factor: float | None = typer.Option(
        None, "--scale-factor", help="Scale factor K1, output unit per g (default: records' "
        "metadata or --model)."),
    model_file: Path | None = typer.Option(
        None, "--model", help="Model file giving K1 and the terms not fitted (default: zero)."),
    fit_frequency: bool = typer.Option(
        False, "--fit-frequency", help="Fit the vibration frequency (Hz) to the reference "
        "channel (IEEE 1057 four-parameter fit) instead of trusting frequency_hz."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    record_out: Path | None = typer.Option(
        None, "--record", help="Write the calibration record (JSON, coefficients in g/g^n): one "
        "per amplitude; with several amplitudes FILE with -1, -2, ... inserted before the "
        "suffix, in increasing amplitude."),
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
    uncertainty: str = uncertainty_options.UNCERTAINTY,
    trials: int = uncertainty_options.TRIALS,
    seed: int = uncertainty_options.SEED,
    force: bool = uncertainty_options.FORCE,
    reference_uncertainty: float = typer.Option(
        0.0, "--reference-uncertainty",
        help="--uncertainty mc: relative standard uncertainty of the reference accelerometer's "
             "sensitivity, % (Gaussian, common to all angles and reference channels).",
    ),
) -> None:
    """Identify k_o, k_p, k_oo, k_pp, k_op (g/g^n) with standard uncertainties."""
    from accelcal.methods import transverse
    from accelcal.model import ErrorModel

    check_format(fmt)
    monte_carlo = uncertainty_options.check(uncertainty, trials, seed)
    reference_sd = uncertainty_options.relative(
        reference_uncertainty, "--reference-uncertainty", monte_carlo)
    names = [t.strip() for t in terms.split(",") if t.strip()]
    base = ErrorModel.load(model_file) if model_file is not None else None
    info = None
    if record_out is not None or serial is not None or operator is not None:
        from accelcal.io.formats.shaker import shaker_files

        inputs = shaker_files(data)
        files = [f for group in inputs.values() for f in group]
        info = record_options.lab_info_for(record_out, files, serial=serial, operator=operator)
    rows = []
    cal = []
    for rec in _read(data):
        if fit_frequency:  # the Monte Carlo below runs at the fitted frequency too
            rec = transverse.with_fitted_frequency(rec)  # noqa: PLW2901
        red = transverse.reduce(rec, route=route, terms=names, base=base,
                                scale_factor=scale_factor)
        red_rows = [{"amplitude_g": rec.amplitude, **r, "method": red.method}
                    for r in red.rows()]
        if monte_carlo:
            with uncertainty_options.progress_bar() as progress:
                mc = transverse.uncertainty(red, rec, trials=trials, seed=seed,
                                            reference_sd=reference_sd, progress=progress,
                                            force=force)
            fitted = len(red.estimate.names)  # the fixed terms' rows follow, without MC columns
            held = dict.fromkeys(mc.columns(0), float("nan"))
            red_rows = (uncertainty_options.merge(red_rows[:fitted], mc)
                        + [{**r, **held} for r in red_rows[fitted:]])
        rows += red_rows
        if info is not None:
            cal += red.to_records(info, input_files=inputs[rec.amplitude])
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(cal, record_out):
            print(f"wrote {p}", file=sys.stderr)
    emit(rows, fmt, title="Cross-axis coefficients from the shaker test")
