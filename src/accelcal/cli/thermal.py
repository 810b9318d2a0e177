"""``accelcal thermal``: thermal-chamber tests (simulate, reduce) and temperature compensation."""

from pathlib import Path

import typer

from accelcal.cli import record_options
from accelcal.cli.common import check_format, check_writable, emit, load_model, parse_grid
from accelcal.cli.input_options import (
    DELIMITER,
    GAPS,
    INPUT_FORMAT,
    JITTER_TOL,
    MAX_FILL,
    RESAMPLE,
    SCALE,
    SORT,
    TIME,
    TIME_UNIT,
    print_reduction_repairs,
    print_repairs,
    repair_options,
)
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=("Thermal-chamber tests (IEEE 1293 style): a multipoint tumble at each temperature "
          "plateau, temperature coefficients with uncertainty, hysteresis, warm-up, and "
          "temperature compensation of recordings."),
    no_args_is_help=True,
)


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Thermal record to write (CSV or .parquet)."),
    model_file: Path | None = typer.Option(
        None, "--model", help="Model file with temperature terms (accelcal model new --set "
                              "K0_T1=... --set T0=25); default: the embedded default "
                              "accelerometer with bias TC 8 ug/degC, scale TC -25 ppm/degC."),
    setpoints: str = typer.Option(
        "-40,-10,20,50,70,35,5,-25", "--setpoints",
        help="Plateau temperatures in test order, degC (list or range start:stop:step)."),
    start: float = typer.Option(25.0, "--start", help="Temperature at turn-on, degC."),
    ramp_rate: float = typer.Option(1.0, "--ramp-rate", help="Chamber ramp rate, degC/min."),
    soak: float = typer.Option(3600.0, "--soak", help="Soak before each tumble, s."),
    warmup: float = typer.Option(1800.0, "--warmup", help="Readings after turn-on, s."),
    points: int = typer.Option(24, "--points", help="Tumble positions per plateau."),
    dwell: float = typer.Option(60.0, "--dwell", help="Time at each position, s."),
    step: float = typer.Option(10.0, "--step", help="Reading interval, s."),
    tau: float = typer.Option(600.0, "--tau", help="Sensor thermal time constant, s."),
    axis: str = typer.Option("OA", "--axis", help="Tumble rotation axis: OA or PA."),
    noise: float = typer.Option(2e-5, "--noise", help="Output noise SD per reading, output "
                                                      "unit."),
    temperature_noise: float = typer.Option(0.01, "--temperature-noise",
                                            help="Temperature reading noise SD, degC."),
    warmup_amplitude: float = typer.Option(50.0, "--warmup-amplitude",
                                           help="Bias change from turn-on to settled, ug."),
    warmup_tau: float = typer.Option(300.0, "--warmup-tau", help="Warm-up time constant, s."),
    hysteresis: float = typer.Option(10.0, "--hysteresis",
                                     help="Bias hysteresis, heating minus cooling, ug."),
    hysteresis_scale: float = typer.Option(
        5.0, "--hysteresis-scale", help="Scale-factor hysteresis, heating minus cooling, ppm."),
    rate_sensitivity: float = typer.Option(
        20.0, "--rate-sensitivity", help="Bias per rate of the sensor temperature, "
                                         "ug per degC/min."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the random generator."),
    force: bool = FORCE,
) -> None:
    """Write a simulated thermal-chamber test (the truth in its metadata)."""
    from accelcal.io.formats import thermal as thermal_format
    from accelcal.rigs.thermal import DEFAULT_TEMPERATURE, Programme
    from accelcal.rigs.thermal import simulate as simulate_thermal

    check_writable(out)
    model = load_model(model_file)
    if model_file is None:
        model = model.replace(temperature=DEFAULT_TEMPERATURE)
    programme = Programme(setpoints=tuple(parse_grid(setpoints, "--setpoints")), start=start,
                          ramp_rate=ramp_rate, soak=soak, warmup=warmup, points=points,
                          dwell=dwell, step=step)
    record = simulate_thermal(
        model, programme, tau=tau, rotation_axis=axis, noise=noise,
        temperature_noise=temperature_noise, warmup_amplitude=warmup_amplitude * 1e-6,
        warmup_tau=warmup_tau, hysteresis=hysteresis * 1e-6,
        hysteresis_scale=hysteresis_scale * 1e-6, rate_sensitivity=rate_sensitivity * 1e-6,
        seed=seed)
    thermal_format.write(out, record)
    typer.echo(f"wrote {out}")


@app.command("reduce")
def reduce(
    file: Path = typer.Argument(..., help="Thermal record (CSV or Parquet, kind thermal)."),
    *,
    gaps: str = GAPS, max_fill: int = MAX_FILL,
    order: str = typer.Option(
        "auto", "--order", help="Polynomial order: 1, 2, 3, or auto (per term, raised while "
                                "the F-test of the added power rejects at 5 %)."),
    reference: float = typer.Option(25.0, "--reference", help="Reference temperature T0, "
                                                              "degC."),
    terms: str | None = typer.Option(
        None, "--terms", help="Terms fitted against temperature, comma separated: K0, K1 "
                              "(always), K2, Kp (about OA) or Ko (about PA); default all."),
    window: float = typer.Option(600.0, "--window", help="Settling window at the end of each "
                                                         "soak, s."),
    rate_limit: float = typer.Option(
        0.01, "--rate-limit", help="A plateau is usable when its sensor temperature changes "
                                   "less than this over the window, degC/min."),
    tolerance: float = typer.Option(0.1, "--tolerance",
                                    help="Band for the reported settling time, degC."),
    compensation: Path | None = typer.Option(
        None, "--compensation", help="Write the compensation model (JSON: K0 and K1 "
                                     "polynomials, T0, valid range)."),
    model_out: Path | None = typer.Option(
        None, "--model-out", help="Write the error model with its temperature terms."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    record_out: Path | None = typer.Option(None, "--record",
                                           help="Write a calibration record (JSON)."),
    serial: str | None = record_options.SERIAL,
    plot: Path | None = typer.Option(None, "--plot", help="Directory for the figures."),
    temperature_sd: float | None = typer.Option(
        None, "--temperature-sd",
        help="Standard uncertainty of each plateau's temperature, degC (default: the standard "
        "error of the mean of its readings), propagated as an effective variance."),
    priors: str = typer.Option(
        "default", "--priors",
        help="Priors of the terms the plateau tumbles take as zero (K0', K1'): default, none "
        "(state only how much each would move each row) or TERM=U,... (standard "
        "uncertainties), propagated as Type B to the rows at T0."),
) -> None:
    """Reduce a thermal test: temperature coefficients, hysteresis and warm-up with uncertainty.

    JSON/CSV rows: coefficient, estimate, std, unit, status, dof and the
    engineering units (ug/degC, ppm/degC, ...); names in docs/thermal.md.
    """
    import sys

    from accelcal.methods import thermal
    from accelcal.methods.tumble.unestimated import parse_priors

    check_format(fmt)
    if order not in ("auto", "1", "2", "3"):
        raise AccelcalError(f"--order {order[:20]!r} is not auto, 1, 2 or 3")
    for path in (compensation, model_out, record_out):
        check_writable(path)
    info = record_options.lab_info_for(record_out, [file], serial=serial, operator=None)
    chosen = [t.strip() for t in terms.split(",")] if terms is not None else None
    red = thermal.reduce(file, order=order if order == "auto" else int(order),
                         reference=reference, terms=chosen, window=window,
                         rate_limit=rate_limit, tolerance=tolerance,
                         temperature_sd=temperature_sd, priors=parse_priors(priors),
                         gaps=gaps, max_fill=max_fill)
    print_reduction_repairs(red)
    if plot is not None:
        for p in red.plot(plot):
            typer.echo(f"wrote {p}", err=True)
    model = red.models[0]
    if compensation is not None:
        thermal.Compensation.from_model(model, description=f"from {file.name}").save(compensation)
        typer.echo(f"wrote {compensation}", err=True)
    if model_out is not None:
        model.save(model_out)
        typer.echo(f"wrote {model_out}", err=True)
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(red.to_records(info, input_files=[file]), record_out):
            typer.echo(f"wrote {p}", err=True)
    emit(red.rows(), fmt, title=f"Thermal reduction ({red.method}, orders "
                                f"{red.assumed('orders')}, dof {red.dof}), {file}")
    from accelcal.interval import statements

    stream = sys.stdout if fmt == "table" else sys.stderr
    for note in (*red.estimate.notes, *statements(red), red.assumption("order_selection").text):
        print(f"note: {note}", file=stream)


@app.command("compensate")
def compensate(
    file: Path = typer.Argument(..., help="Recording with an output and a temperature column "
                                          "(CSV, Parquet, TDMS, HDF5, MAT or a record)."),
    *,
    model: Path = typer.Option(..., "--model", help="Compensation model (thermal reduce "
                                                    "--compensation) or a model file with "
                                                    "temperature terms and a valid range."),
    out: Path = typer.Option(..., "--out", help="CSV to write: one row per input row."),
    column: str = typer.Option("output", "--column", help="The output's column."),
    temperature_column: str = typer.Option("temperature", "--temperature-column",
                                           help="The sensor temperature's column."),
    temperature_unit: str | None = typer.Option(
        None, "--temperature-unit", help="degC or K (default: the file's, e.g. a record's)."),
    unit: str | None = typer.Option(
        None, "--unit", help="Unit of the output column (default: the model's output unit)."),
    scale: float | None = SCALE,
    input_format: str = INPUT_FORMAT, time: str | None = TIME, time_unit: str = TIME_UNIT,
    delimiter: str | None = DELIMITER,
    gaps: str = GAPS, max_fill: int = MAX_FILL, sort: bool = SORT,
    jitter_tol: float | None = JITTER_TOL, resample: bool = RESAMPLE,
    allow_extrapolation: bool = typer.Option(
        False, "--allow-extrapolation", help="Compensate temperatures outside the valid range "
                                             "too, flagging those rows (extrapolated = 1)."),
) -> None:
    """Apply a temperature compensation to a recording, streamed (a_i = E/K1(T) - K0(T))."""
    from accelcal.io.recordings import TEMPERATURE_UNITS, InputOptions, describe, iter_blocks
    from accelcal.io.recordings.repairs import Repairs
    from accelcal.io.recordings.sources import open_source
    from accelcal.methods.thermal import Compensation, compensate_stream

    check_writable(out)
    comp = Compensation.load(model)
    if temperature_unit is not None and temperature_unit not in TEMPERATURE_UNITS:
        raise AccelcalError(f"--temperature-unit {temperature_unit[:20]!r} is not degC or K")
    source = open_source(file, input_format, "\t" if delimiter == "\\t" else delimiter)
    stated = source.metadata.get("units", {}) if source.input_format == "record" else {}
    stated = stated if isinstance(stated, dict) else {}
    t_unit = temperature_unit or stated.get(temperature_column)
    opts = InputOptions(
        input_format=input_format, columns=(column, temperature_column), time=time,
        time_unit=time_unit, unit=unit or stated.get(column) or comp.output_unit,
        units={temperature_column: t_unit} if t_unit in TEMPERATURE_UNITS else None,
        scales=None if scale is None else {column: scale},
        delimiter="\t" if delimiter == "\\t" else delimiter,
        **repair_options(gaps, max_fill, sort, jitter_tol, resample))
    try:
        prov, _ = describe(file, opts, need_rate=False, what="recording to compensate",
                           digest=False)
    except AccelcalError as exc:
        if exc.parameter != "columns":
            raise
        raise AccelcalError(exc.message.replace("columns=...", "--column and "
                                                "--temperature-column")) from None
    units = prov.get("units") or dict.fromkeys(prov["columns"], prov["unit"])
    if units[temperature_column] not in TEMPERATURE_UNITS:
        raise AccelcalError(f"the temperature column {temperature_column[:40]!r} has no "
                            "temperature unit; give --temperature-unit degC or K")
    if units[column] != comp.output_unit:
        raise AccelcalError(f"the compensation maps outputs in {comp.output_unit}, the column "
                            f"{column[:40]!r} is in {units[column]}; give --unit "
                            f"{comp.output_unit} if it is")
    repairs = Repairs()
    blocks = iter_blocks(file, opts, need_rate=False, what="recording to compensate",
                         repairs=repairs)
    rows = compensate_stream(blocks, out, comp, names=(column, temperature_column),
                             offset=TEMPERATURE_UNITS[units[temperature_column]],
                             allow_extrapolation=allow_extrapolation)
    typer.echo(f"wrote {out} ({rows} rows)", err=True)
    print_repairs(repairs)
