"""``accelcal triad``: accelerometer triads on static positions (detect, calibrate, apply)."""

from pathlib import Path

import typer

from accelcal.cli import record_options, triad_plan, uncertainty_options
from accelcal.cli.common import check_format, check_writable, emit
from accelcal.cli.input_options import (
    COLUMNS,
    DELIMITER,
    GAPS,
    INPUT_FORMAT,
    JITTER_TOL,
    MAX_FILL,
    RAILS,
    RATE,
    REGIONS,
    RESAMPLE,
    SCALE,
    SORT,
    TIME,
    TIME_UNIT,
    UNIT,
    input_options,
    print_repairs,
    repair_options,
    static_rails,
)
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError
from accelcal.formatting import unit_squared

app = typer.Typer(
    help=("Accelerometer triads on static positions (Tedaldi 2014, Ferraris 1995): static "
          "intervals, calibration with uncertainty (known or unknown orientations), applying "
          "a calibration to a recording, simulated triads."),
    no_args_is_help=True,
)

_FILE_HELP = "The recording: CSV, Parquet, an imucal session, an imu_tk file or a triad record."
INIT_STATIC = typer.Option(
    30.0, "--init-static",
    help="Length of the still period at the start of the recording, s (Tedaldi: 30-50 s); "
         "the threshold is relative to its variance.")
WINDOW = typer.Option(1.0, "--window", help="Window of the moving variance, s (1-2 s).")
MIN_LENGTH = typer.Option(2.0, "--min-length", help="Shortest static interval kept, s.")
PLOT = typer.Option(None, "--plot", help="Directory for the figures (PNG and SVG).")
DETECT_ROWS = 1 << 18
"""Rows per block of ``triad detect``'s stream (6 MiB of three float64 channels): the
moving variance's few copies of a block stay well under the 300 MiB the command may take."""


def _save_intervals_figure(intervals, rec, plot: Path) -> None:
    from accelcal.plotting import save_figure
    from accelcal.signal.static import figure

    for p in save_figure(figure(intervals, rec.values, time=rec.time), plot, "triad-intervals"):
        typer.echo(f"wrote {p}", err=True)


@app.command("detect")
def detect(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    *,
    input_format: str = INPUT_FORMAT, columns: str | None = COLUMNS, time: str | None = TIME,
    time_unit: str = TIME_UNIT, rate: float | None = RATE, unit: str | None = UNIT,
    scale: float | None = SCALE, delimiter: str | None = DELIMITER,
    gaps: str = GAPS, max_fill: int = MAX_FILL, sort: bool = SORT,
    jitter_tol: float | None = JITTER_TOL, resample: bool = RESAMPLE, rails: str | None = RAILS,
    init_static: float = INIT_STATIC, window: float = WINDOW,
    factor: float = typer.Option(
        2.0, "--factor", help="Threshold: this many times the initial period's variance "
                              "magnitude (Tedaldi sweeps 2-10)."),
    min_length: float = MIN_LENGTH,
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = PLOT,
) -> None:
    """List the static intervals of a recording: times, lengths, means and noise per axis.

    The recording streams in blocks (memory bounded by a block, the initial
    still period and a window: a day at 1 kHz is fine), with progress.
    """
    from accelcal.cli.progress import DelayedProgress
    from accelcal.io.recordings import describe, iter_blocks
    from accelcal.io.recordings.repairs import Repairs
    from accelcal.methods.triad.lab import note_clipped, note_excluded
    from accelcal.signal.clipping import ClipFinder
    from accelcal.signal.static import check_settings
    from accelcal.signal.static_stream import detect_static_stream

    check_format(fmt)
    check_settings(init_static=init_static, window=window, factor=factor,
                   min_length=min_length)
    clipping = ClipFinder(3, static_rails(rails))
    opts = input_options(input_format=input_format, columns=columns, time=time,
                         time_unit=time_unit, rate=rate, unit=unit, scale=scale,
                         delimiter=delimiter,
                         **_repair_options(gaps, max_fill, sort, jitter_tol, resample))
    prov, sample_rate = describe(file, opts, channels=3, what="triad recording", digest=False,
                                 rows=DETECT_ROWS)
    repairs = Repairs()
    blocks = iter_blocks(file, opts, channels=3, what="triad recording", repairs=repairs,
                         rows=DETECT_ROWS)
    with DelayedProgress(f"static intervals of {file.name}") as progress:
        try:
            (found,) = detect_static_stream(
                blocks, sample_rate, init_static=init_static, window=window, factors=(factor,),
                min_length=min_length, unit=prov["unit"], exclude=clipping,
                trace_points=20_000 if plot is not None else 0,  # the figure's, if drawn
                progress=lambda done: progress(done, done))  # the length is not known ahead
        finally:
            note_clipped(repairs, clipping)
    note_excluded(repairs, found.excluded)
    if plot is not None:
        from accelcal.plotting import save_figure
        from accelcal.signal.static import figure

        for p in save_figure(figure(found), plot, "triad-intervals"):
            typer.echo(f"wrote {p}", err=True)
    emit(found.rows(), fmt,
         title=f"{file}: {len(found)} static intervals (threshold {found.threshold:.4g} "
               f"{unit_squared(prov['unit'])} = {factor:g} x the first {init_static:g} s)")
    print_repairs(repairs)


def _repair_options(gaps, max_fill, sort, jitter_tol, resample) -> dict:
    """The repair options of a triad command (a split recording is refused)."""
    if gaps == "split":
        raise AccelcalError("--gaps split: static intervals need consecutive samples; give "
                            "--gaps fill, or split the file at its gaps", parameter="gaps")
    return repair_options(gaps, max_fill, sort, jitter_tol, resample)


@app.command("calibrate")
def calibrate(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    *,
    input_format: str = INPUT_FORMAT, columns: str | None = COLUMNS, time: str | None = TIME,
    time_unit: str = TIME_UNIT, rate: float | None = RATE, unit: str | None = UNIT,
    scale: float | None = SCALE, delimiter: str | None = DELIMITER, regions: Path | None = REGIONS,
    gaps: str = GAPS, max_fill: int = MAX_FILL, sort: bool = SORT,
    jitter_tol: float | None = JITTER_TOL, resample: bool = RESAMPLE, rails: str | None = RAILS,
    orientations: str | None = typer.Option(
        None, "--orientations",
        help="known (imucal labels or --regions, a triad record's positions, or --positions) "
             "or unknown (gravity norm on the detected intervals); default: known when the "
             "file or --positions gives them, else unknown."),
    positions: Path | None = typer.Option(
        None, "--positions",
        help="JSON list of the up vector [x, y, z] of each detected static interval, in order "
             "(or {\"label\": ..., \"up\": [x, y, z]} items): known orientations for any file."),
    gravity: float | None = typer.Option(None, "--gravity", help="Local gravity, m/s^2."),
    latitude: float | None = typer.Option(
        None, "--latitude", help="Geodetic latitude, deg (WGS84 normal gravity)."),
    height: float | None = typer.Option(None, "--height", help="Height, m (with --latitude)."),
    quadratic: bool = typer.Option(False, "--quadratic", help="Fit per-axis quadratic terms."),
    estimator: str | None = typer.Option(
        None, "--estimator",
        help="Known orientations: least-squares (all positions), pairs (Ferraris's per-axis "
             "pairs on six positions, as imucal: a tilted fixture moves the biases only at "
             "second order) or gls (weighs each reading by the noise and --fixture-tilt); "
             "default gls with --fixture-tilt, else least-squares."),
    fixture_tilt: str | None = typer.Option(
        None, "--fixture-tilt",
        help="Known orientations: standard uncertainty of each position's tilt (Type B), "
             "with its unit, e.g. 5mrad, 0.3deg, 60arcsec; the interval means' noise is then "
             "their samples' SD / sqrt(n)."),
    init_static: float = INIT_STATIC, window: float = WINDOW,
    factor: float | None = typer.Option(
        None, "--factor",
        help="Threshold factor of the static detection; default: with unknown orientations "
             "the one of 2..10 whose calibration leaves the smallest norm residual "
             "(Tedaldi), else 2."),
    min_length: float = MIN_LENGTH,
    out: Path = typer.Option(..., "--out", help="Calibration file to write (accelcal JSON)."),
    imucal_out: Path | None = typer.Option(
        None, "--imucal-out", help="Also write the calibration in imucal's JSON layout."),
    fmt: str = typer.Option("table", "--format", help="Output format: table or json."),
    record_out: Path | None = typer.Option(
        None, "--record", help="Write a calibration record (JSON) of the triad."),
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
    plot: Path | None = PLOT,
    uncertainty: str = uncertainty_options.UNCERTAINTY,
    trials: int = uncertainty_options.TRIALS,
    seed: int = uncertainty_options.SEED,
    force: bool = uncertainty_options.FORCE,
    priors: str = typer.Option(
        "none", "--priors",
        help="Each axis's pendulous error terms the triad model leaves out (K2, K3, Koo, Kpp, "
             "Kio, Kip, Kop, K0', K1'), when the axes are pendulous accelerometers: none (the "
             "default, a MEMS triad: state only how much each would move each row, per unit "
             "term), default (twice the embedded default accelerometer's magnitude, "
             "rectangular), a JSON file {TERM: U or {\"value\": a, \"distribution\": ...}} "
             "or TERM=U,... (standard uncertainties in g/g^n; K2[x] for one axis), propagated "
             "as Type B."),
) -> None:
    """Calibrate a triad: bias, scale factor and non-orthogonality with their uncertainty.

    Writes the calibration (--out; --imucal-out for imucal), prints the
    coefficients and the norm residual |a| - g of every position before and
    after calibration.
    """
    from accelcal.methods.triad.common import calibration_of
    from accelcal.methods.triad.lab import run
    from accelcal.methods.triad.unestimated import parse_priors

    check_format(fmt)
    bounds = parse_priors(priors)
    if fmt == "csv":
        raise AccelcalError("--format csv: calibrate prints two tables (coefficients and "
                            "positions); use table or json")
    if imucal_out is not None and quadratic:
        raise AccelcalError("--imucal-out: imucal's layout has no quadratic terms; drop "
                            "--quadratic")
    monte_carlo = uncertainty_options.check(uncertainty, trials, seed)
    tilt = None if fixture_tilt is None else parse_angle(fixture_tilt, "--fixture-tilt")
    for path in (out, imucal_out, record_out):
        check_writable(path)
    opts = input_options(input_format=input_format, columns=columns, time=time,
                         time_unit=time_unit, rate=rate, unit=unit, scale=scale,
                         delimiter=delimiter, regions=regions,
                         **_repair_options(gaps, max_fill, sort, jitter_tol, resample))
    lab = run(file, options=opts, orientations=orientations, positions=positions,
              gravity=gravity, latitude=latitude, height=height, quadratic=quadratic,
              init_static=init_static, window=window, factor=factor, min_length=min_length,
              estimator=estimator, fixture_tilt=tilt, priors=bounds, rails=static_rails(rails))
    red, rec, found = lab.reduction, lab.recording, lab.intervals
    print_repairs(rec.repairs)
    files = [file] if rec.provenance.get("input_format") == "record" else []
    info = record_options.lab_info_for(record_out, files, serial=serial, operator=operator)
    rows = red.rows()
    if monte_carlo:
        from accelcal.methods.triad.mc import triad_uncertainty

        with uncertainty_options.progress_bar() as progress:
            mc = triad_uncertainty(red, trials=trials, seed=seed, progress=progress,
                                   force=force)
        rows = uncertainty_options.merge(rows, mc)
    cal = calibration_of(red)
    if plot is not None:  # figures first: a bad directory stops before any file is written
        for p in red.plot(plot):
            typer.echo(f"wrote {p}", err=True)
        if found is not None:
            _save_intervals_figure(found, rec, plot)
    cal.save(out)
    typer.echo(f"wrote {out}", err=True)
    if imucal_out is not None:
        from accelcal.methods.triad.imucal import write_imucal

        write_imucal(cal, imucal_out, comment=f"from {file.name}")
        typer.echo(f"wrote {imucal_out}", err=True)
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(red.to_records(info, input_files=[file]), record_out):
            typer.echo(f"wrote {p}", err=True)
    _print_calibration(lab, rows, fmt=fmt, file=file)


ANGLE_UNITS = {"rad": 1.0, "mrad": 1e-3, "urad": 1e-6, "µrad": 1e-6, "deg": 0.017453292519943295,
               "arcmin": 2.908882086657216e-4, "arcsec": 4.84813681109536e-6}
"""Units of an angle given on the command line, in rad."""


def parse_angle(text: str, option: str) -> float:
    """An angle with its unit (``5mrad``, ``0.3 deg``), in rad."""
    import re

    match = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([a-zµ]+)\s*", text)
    try:
        return float(match.group(1)) * ANGLE_UNITS[match.group(2)]
    except (AttributeError, KeyError, ValueError):
        raise AccelcalError(f"{option} {text[:40]!r} is not an angle with its unit (e.g. 5mrad, "
                            "0.3deg; units " + ", ".join(ANGLE_UNITS) + ")") from None


def _print_calibration(lab, rows, *, fmt: str, file: Path) -> None:
    import json

    red, sweep = lab.reduction, lab.sweep
    positions = lab.norm_rows()
    summary = lab.summary()
    if fmt == "json":
        from accelcal.cli.common import _json_value

        doc = {**summary, "coefficients": rows, "norm_residuals": positions,
               "factor_sweep": sweep or []}
        typer.echo(json.dumps(_json_value(doc), indent=2, allow_nan=False))
        return
    emit(rows, "table", title=f"{file}: {red.method}, g = {summary['gravity']:.7g} m/s^2, "
                              f"dof {summary['dof']}")
    emit(positions, "table", title="norm residual |a| - g per position, m/s^2")
    if sweep:
        emit(sweep, "table", title="threshold factor sweep (Tedaldi)")
    typer.echo(f"condition number {summary['condition_number']:.3g}")
    from accelcal.interval import statements

    for note in (*red.notes, *statements(red)):
        typer.echo(f"note: {note}")


@app.command("apply")
def apply(
    file: Path = typer.Argument(..., help=_FILE_HELP),
    *,
    calibration: Path = typer.Option(
        ..., "--calibration", help="Calibration file: accelcal's (triad calibrate --out) or "
                                   "imucal's JSON (K_a, R_a, b_a)."),
    input_format: str = INPUT_FORMAT, columns: str | None = COLUMNS, time: str | None = TIME,
    time_unit: str = TIME_UNIT, rate: float | None = RATE,
    unit: str | None = typer.Option(
        None, "--unit", help="Unit of the values (default: the calibration's input unit; an "
                             "acceleration unit is converted to it)."),
    scale: float | None = SCALE, delimiter: str | None = DELIMITER,
    output_unit: str = typer.Option("m/s^2", "--output-unit", help="m/s^2 or g (g_n)."),
    gaps: str = GAPS, max_fill: int = MAX_FILL, sort: bool = SORT,
    jitter_tol: float | None = JITTER_TOL, resample: bool = RESAMPLE,
    rails: str | None = typer.Option(
        None, "--rails",
        help="The clipping levels LOW,HIGH (in --unit, after --scale): runs of 3 or more "
             "samples at or beyond one are clipped: refused, or left out with --gaps split. "
             "Default: not looked for."),
    out: Path = typer.Option(..., "--out", help="CSV file to write."),
) -> None:
    """Correct a recording: one output row per input row, in order (streamed).

    The three channels become acc_x, acc_y, acc_z (calibrated specific force in
    the body frame; the fixture frame for a known-orientation or imucal
    calibration, as imucal gives it); every other column (time, labels, ...) is
    copied as it is. With a repair (--gaps split or fill, --sort, --jitter-tol,
    --rails) the rows are the repaired ones: t (s from the first sample) and
    acc_x, acc_y, acc_z, the other columns not copied; what was found and done
    is listed as notes.
    """
    from accelcal.io.recordings import describe, iter_blocks
    from accelcal.io.recordings.options import ACCELERATION_UNITS
    from accelcal.io.recordings.repairs import Repairs
    from accelcal.io.recordings.sources import open_source
    from accelcal.methods.triad.imucal import apply_repaired, apply_stream, read_calibration

    if output_unit not in ("m/s^2", "g"):
        raise AccelcalError(f"--output-unit {output_unit!r} is not m/s^2 or g")
    check_writable(out)
    cal = read_calibration(calibration, input_unit=unit)
    source = open_source(file, input_format, delimiter)
    if unit is None and source.input_format in ("csv", "parquet", "imu_tk"):
        unit = cal.input_unit
    rails = None if rails is None or rails.strip().lower() == "none" else rails
    repaired = gaps != "refuse" or sort or jitter_tol is not None or rails is not None
    opts = input_options(input_format=input_format, columns=columns, time=time,
                         time_unit=time_unit, rate=rate, unit=unit, scale=scale,
                         delimiter=delimiter, rails=rails,
                         **repair_options(gaps, max_fill, sort, jitter_tol, resample))
    prov, _ = describe(file, opts, channels=3, need_rate=False, what="triad recording",
                       digest=False)
    factor = 1.0
    if prov["unit"] != cal.input_unit:
        if prov["unit"] not in ACCELERATION_UNITS or cal.input_unit not in ACCELERATION_UNITS:
            raise AccelcalError(f"the calibration maps {cal.input_unit}, the recording is in "
                                f"{prov['unit']}; give --unit {cal.input_unit} if it is")
        factor = ACCELERATION_UNITS[prov["unit"]] / ACCELERATION_UNITS[cal.input_unit]
    out_scale = 1.0 / ACCELERATION_UNITS[output_unit]
    channels = prov["columns"]
    frame = "reference" if cal.rotation is not None else "body"
    repairs = Repairs()
    blocks = iter_blocks(file, opts, channels=3, need_rate=False, what="triad recording",
                         repairs=repairs)

    def correct(u):
        return cal.apply(u * factor, frame=frame) * out_scale

    if repaired:
        apply_repaired(blocks, out, correct)
    else:
        apply_stream(_row_for_row(blocks, repairs, file), source, channels, out, correct)
    typer.echo(f"wrote {out}", err=True)
    print_repairs(repairs)


def _row_for_row(blocks, repairs, file):
    """The blocks, refused as soon as the reader leaves out a row (the copy would shift)."""
    for block in blocks:
        if repairs:
            first = repairs.notes()[0].removeprefix("note: ")
            raise AccelcalError(f"{file}: {first}; the other columns can no longer be copied "
                                "row for row: give a repair option (e.g. --gaps split) to "
                                "write the repaired rows")
        yield block


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Triad record file to write (CSV or .parquet)."),
    positions: str = typer.Option(
        "six", "--positions",
        help="six (x, y, z up then down, imucal's order) or a number of random orientations."),
    truth: Path | None = typer.Option(
        None, "--truth", help="The simulated triad's calibration (accelcal or imucal JSON); "
                              "default: a MEMS-like triad in m/s^2."),
    rate: float = typer.Option(100.0, "--rate", help="Sample rate, Hz."),
    dwell: float = typer.Option(5.0, "--dwell", help="Seconds held at each position."),
    motion: float = typer.Option(2.0, "--motion", help="Seconds of each motion between them."),
    still: float = typer.Option(30.0, "--still", help="Initial still period, s."),
    noise: float = typer.Option(0.01, "--noise", help="Noise SD per sample and axis, input unit."),
    gravity: float = typer.Option(9.80665, "--gravity", help="Local gravity, m/s^2."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random generator (integer >= 0)."),
    axis_model: str | None = typer.Option(
        None, "--axis-model",
        help="Simulate each axis as a pendulous accelerometer: default (the embedded default "
             "accelerometer's K2, K3, cross-coupling, odd-input and asymmetry terms on every "
             "axis) or a model file; default: the triad model alone."),
    force: bool = FORCE,
) -> None:
    """Write a simulated triad recording (true calibration, positions and noise in its metadata)."""
    from accelcal.io.formats import triad as triad_format
    from accelcal.methods.triad.imucal import read_calibration
    from accelcal.methods.triad.model import TriadCalibration
    from accelcal.rigs.triad import simulate as simulate_triad
    from accelcal.rigs.triad import six_positions

    if positions.strip() == "six":
        up = six_positions()
    elif positions.strip().isdigit():
        up = int(positions)
    else:
        raise AccelcalError(f"--positions {positions[:40]!r} is not 'six' or a number")
    check_writable(out)
    cal = (TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
           if truth is None else read_calibration(truth))
    models = None
    if axis_model is not None:
        from accelcal.cli.common import load_model

        models = "default" if axis_model.strip() == "default" else \
            (load_model(Path(axis_model)),) * 3
    record = simulate_triad(cal, up, rate=rate, dwell=dwell, motion=motion, still=still,
                            noise_sd=noise, seed=seed, gravity=gravity, axis_models=models)
    triad_format.write(out, record)
    typer.echo(f"wrote {out}")


app.command("plan")(triad_plan.plan)
