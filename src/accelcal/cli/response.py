"""``accelcal response``: frequency response by comparison, laser or gravity, and its model.

``simulate`` writes a record (stepped sine, random or swept excitation, a
laser interferometer's signals or a rotation in gravity; its reference's
certificate, the DAQ's channel mismatch and the DUT's true transfer
function in its metadata); ``reduce`` gives magnitude and phase per step
or bin with their standard uncertainties and the deviation from the
reference frequency (``--method stepped|broadband|laser|gravity``, by
default the record's own); ``fit`` fits the transfer function and gives its
parameters, the -3 dB bandwidth, the resonance and the phase at stated
frequencies; ``plan`` gives the periods or averages a stated uncertainty
needs. A step with too few periods, a frequency not found in the data, a
reference table that does not cover the band or no bin of enough
coherence exit with status 2 and one line.
"""

from pathlib import Path

import typer

from accelcal.cli import record_options
from accelcal.cli.common import check_format, check_writable, emit, parse_grid
from accelcal.cli.input_options import GAPS, MAX_FILL, print_reduction_repairs
from accelcal.cli.uncertainty_options import FORCE, forced

app = typer.Typer(
    help="Frequency response of an accelerometer: by comparison with a reference on a shaker "
         "(ISO 16063-21, stepped sine or broadband), by laser interferometry (ISO 16063-11) "
         "or by gravity on a rotating table (ISO 16063-16): simulate records, reduce them to "
         "magnitude and phase, fit the transfer function, plan the test.",
    no_args_is_help=True,
)

_REFERENCE = typer.Option(
    None, "--reference",
    help="The reference's certificate, a CSV table frequency_hz,magnitude,phase_deg "
         "(magnitude in V/g, phase in deg); default: the one each record states.")
_FORMAT = typer.Option("table", "--format", help="table, csv or json.")
_PLOT = typer.Option(None, "--plot", help="Directory for the Bode figure.")
_RECORD = typer.Option(
    None, "--record", help="Write the calibration record (JSON) of the result, for "
    "accelcal certificate, report, budget and the store; the serial number from the records' "
    "metadata or --serial.")


def _lab_info(record_out, files, serial, operator):
    """The laboratory metadata of ``--record`` (checked before any reduction; None without)."""
    return record_options.lab_info_for(record_out, [Path(f) for f in files], serial=serial,
                                       operator=operator)


def _save(result, info, record_out, files) -> None:
    if info is None:
        return
    import sys

    from accelcal.calibration import save_records

    for p in save_records(result.to_records(info, input_files=[Path(f) for f in files]),
                          record_out):
        print(f"wrote {p}", file=sys.stderr)


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Response record to write (CSV or .parquet)."),
    frequencies: str | None = typer.Option(
        None, "--frequencies",
        help="Step frequencies, Hz (list or range start:stop:step); default "
             "10,20,40,80,160,315,500,630,800,1000,1250 (laser: 100,200,400,800,1600; "
             "gravity, the rotation rates: 0.25,0.5,1,2,4)."),
    amplitude: float | None = typer.Option(
        None, "--amplitude", help="Acceleration amplitude, g (default 1; stepped, random and "
                                  "swept)."),
    sample_rate: float | None = typer.Option(
        None, "--sample-rate", help="Sample rate, Hz (default 20000; random and swept 10000, "
                                    "laser 1e6, gravity 1000)."),
    periods: int | None = typer.Option(None, "--periods", help="Whole periods recorded per "
                                                               "step (default 20; gravity 4)."),
    s0: float = typer.Option(1.3, "--s0", help="DUT static sensitivity, output unit per g."),
    fn: float = typer.Option(600.0, "--fn", help="DUT natural frequency, Hz."),
    zeta: float = typer.Option(0.6, "--zeta", help="DUT damping ratio."),
    pole: float | None = typer.Option(None, "--pole", help="DUT extra pole, Hz (none)."),
    delay: float = typer.Option(0.0, "--delay", help="DUT pure delay, s."),
    gain_ratio: float | None = typer.Option(
        None, "--gain-ratio", help="DAQ: DUT channel gain over the reference's (default 1; "
                                   "not gravity)."),
    daq_delay: float | None = typer.Option(
        None, "--daq-delay", help="DAQ: DUT channel delay behind the reference's, s (default "
                                  "0; not gravity)."),
    distortion: str | None = typer.Option(
        None, "--distortion", help="Shaker's 2nd and 3rd harmonics, fractions d2,d3 (default "
                                   "0,0; stepped and laser)."),
    noise: float = typer.Option(1e-4, "--noise", help="White noise of each channel, V rms "
                                                      "(0: an exact record)."),
    unit: str = typer.Option("V", "--unit", help="DUT output unit: V, mV or mA."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the random generator."),
    excitation: str = typer.Option(
        "stepped", "--excitation",
        help="stepped, random or swept (broadband: --band, --duration, --amplitude the "
             "level in g), laser (ISO 16063-11: --displacement; --frequencies, --periods) or "
             "gravity (ISO 16063-16: --frequencies the rotation rates). Options of another "
             "excitation are refused (--amplitude: stepped, random, swept; --gain-ratio, "
             "--daq-delay: not gravity; --distortion: stepped and laser)."),
    band: str | None = typer.Option(None, "--band", help="Broadband: lo,hi, Hz (default "
                                                         "5,2000)."),
    duration: float | None = typer.Option(None, "--duration",
                                          help="Broadband: record length, s (default 20)."),
    displacement: float | None = typer.Option(
        None, "--displacement", help="Laser: displacement amplitude, m (default 2e-6)."),
    force: bool = FORCE,
) -> None:
    """Write a simulated frequency-response record (the truth in its metadata)."""
    from accelcal.errors import AccelcalError
    from accelcal.io.formats import response as response_format
    from accelcal.rigs import response_routes as routes
    from accelcal.rigs.shaker_response import DutResponse, ResponseRig

    check_writable(out)
    dut = DutResponse(S0=s0, fn_hz=fn, zeta=zeta, pole_hz=pole, delay_s=delay)
    own = {"--band": (band, ("random", "swept")), "--duration": (duration, ("random", "swept")),
           "--displacement": (displacement, ("laser",)),
           "--frequencies": (frequencies, ("stepped", "laser", "gravity")),
           "--periods": (periods, ("stepped", "laser", "gravity")),
           "--amplitude": (amplitude, ("stepped", "random", "swept")),
           "--gain-ratio": (gain_ratio, ("stepped", "random", "swept", "laser")),
           "--daq-delay": (daq_delay, ("stepped", "random", "swept", "laser")),
           "--distortion": (distortion, ("stepped", "laser"))}
    for option, (value, kinds) in own.items():
        if value is not None and excitation not in kinds:
            raise AccelcalError(f"{option} does not apply to --excitation {excitation}")
    given = {k: v for k, v in (("sample_rate", sample_rate), ("periods", periods)) if v is not None}
    if frequencies is not None:
        given["frequencies"] = tuple(parse_grid(frequencies, "--frequencies"))
    dist = parse_grid(distortion, "--distortion") if distortion is not None else (0.0, 0.0)
    if len(dist) != 2:
        raise AccelcalError("--distortion: give two fractions, d2,d3")
    amplitude = 1.0 if amplitude is None else amplitude
    gain_ratio = 1.0 if gain_ratio is None else gain_ratio
    daq_delay = 0.0 if daq_delay is None else daq_delay
    if excitation == "stepped":
        rig = ResponseRig(**given, amplitudes=(amplitude,), gain_ratio=gain_ratio,
                          delay_s=daq_delay, distortion=tuple(dist), noise=noise)
    elif excitation in ("random", "swept"):
        if band is not None:
            given["band_hz"] = tuple(parse_grid(band, "--band"))
        if duration is not None:
            given["duration_s"] = duration
        rig = routes.BroadbandRig(**given, kind=excitation, level_g=amplitude,
                                  gain_ratio=gain_ratio,
                                  delay_s=daq_delay, noise=noise)
    elif excitation == "laser":
        if displacement is not None:
            given["displacement_m"] = displacement
        rig = routes.LaserRig(**given, gain_ratio=gain_ratio,
                              delay_s=daq_delay, distortion=tuple(dist), noise=noise)
    elif excitation == "gravity":
        rig = routes.GravityRig(**given, noise=noise)
    else:
        raise AccelcalError(f"--excitation {excitation!r} is not one of stepped, random, "
                            "swept, laser, gravity")
    if excitation == "stepped":  # a loop of steps: progress when the run is long
        from accelcal.cli.progress import DelayedProgress

        with DelayedProgress("response simulate steps") as progress:
            record = rig.simulate(dut, seed=seed, unit=unit, progress=progress)
    else:
        record = rig.simulate(dut, seed=seed, unit=unit)
    response_format.write(out, record)
    typer.echo(f"wrote {out}")


def _reduced(files, reference, reference_frequency, **options):
    from accelcal.methods.response import reduce as reduce_response

    red = reduce_response([Path(f) for f in files], reference=reference,
                          reference_frequency=reference_frequency, **options)
    print_reduction_repairs(red)
    return red


def _plot(reduction, plot: Path | None, **context) -> None:
    if plot is None:
        return
    from accelcal.errors import AccelcalError
    from accelcal.methods.response import figures
    from accelcal.plotting import save_figure

    if not plot.is_dir():
        raise AccelcalError(f"--plot {plot} is not a directory; create it first")
    for stem, _, fig, _ in figures(reduction, **context):
        save_figure(fig, plot, stem)


@app.command("reduce")
def reduce(
    files: list[Path] = typer.Argument(..., help="Response records (kind response)."),
    *,
    reference: Path | None = _REFERENCE,
    reference_frequency: float | None = typer.Option(
        None, "--reference-frequency",
        help="Frequency of the deviations, Hz: the step nearest it (default 80 Hz; gravity: "
             "the lowest rate)."),
    method: str | None = typer.Option(
        None, "--method",
        help="stepped (comparison, ISO 16063-21), broadband (random or swept: H1 and "
             "coherence, the file streamed), laser (ISO 16063-11 method 3) or gravity (ISO "
             "16063-16); default: the record's excitation."),
    segment: int | None = typer.Option(
        None, "--segment", help="Broadband: samples per Welch segment (default: bins no "
                                "wider than the band's low edge)."),
    min_coherence: float | None = typer.Option(
        None, "--min-coherence", help="Broadband: bins of lower coherence are left out "
                                      "(default 0.9)."),
    static_scale_factor: str | None = typer.Option(
        None, "--static-scale-factor",
        help="Gravity: the static scale factor and its standard uncertainty (value,u, "
             "output unit per g, e.g. a tumble's K1) to tie the lowest rate to."),
    gaps: str = GAPS, max_fill: int = MAX_FILL,
    fmt: str = _FORMAT,
    plot: Path | None = _PLOT,
    record_out: Path | None = _RECORD,
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
) -> None:
    """Magnitude and phase of the DUT's sensitivity per step or bin, with uncertainties.

    The CSV header is frequency_hz,magnitude,magnitude_u,phase_deg,phase_u,unit,
    deviation_pct,deviation_pct_u,deviation_db (magnitude in the output unit per g).
    """
    from accelcal.errors import AccelcalError
    from accelcal.methods.response import response_rows

    check_format(fmt)
    tie = None
    if static_scale_factor is not None:
        tie = parse_grid(static_scale_factor, "--static-scale-factor")
        if len(tie) != 2:
            raise AccelcalError("--static-scale-factor: give value,u")
    info = _lab_info(record_out, files, serial, operator)
    red = _reduced(files, reference, reference_frequency, method=method, segment=segment,
                   min_coherence=min_coherence, static_scale_factor=tie, gaps=gaps,
                   max_fill=max_fill)
    _plot(red, plot)
    _save(red, info, record_out, files)
    title = f"frequency response, {red.method} ({len(files)} record(s))"
    if any(a.name == "static_tie" for a in red.assumptions):
        dev, u, f_low = red.assumed("static_tie")
        title += (f"; |S({f_low:g} Hz)| / static scale factor - 1 = {1e6 * dev:.3g} ± "
                  f"{1e6 * u:.2g} ppm")
    if any(a.name == "flagged" for a in red.assumptions):
        steps = red.assumed("flagged")
        title += (f"; {len(steps)} step(s) flagged at import, coherence below the limit: "
                  + ", ".join(f"{f:g} Hz" for f in steps))
    flagged = red.observations.get("flagged_hz")
    if flagged is not None and len(flagged):
        title += f"; {len(flagged)} bin(s) below the coherence limit left out"
    emit(response_rows(red), fmt, title=title)


@app.command("fit")
def fit(
    file: Path = typer.Argument(..., help="Response record (kind response)."),
    *,
    model: str = typer.Option("second-order", "--model",
                              help="second-order, optionally with ,pole and ,delay."),
    reference: Path | None = _REFERENCE,
    phase_at: str = typer.Option("", "--phase-at",
                                 help="Frequencies at which to give the phase, Hz (list)."),
    gaps: str = GAPS, max_fill: int = MAX_FILL,
    fmt: str = _FORMAT,
    plot: Path | None = _PLOT,
    record_out: Path | None = _RECORD,
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
) -> None:
    """The transfer function fitted to the frequency response, and what it gives.

    Rows coefficient,estimate,std,unit: S0 (output unit per g), fn (Hz), zeta,
    pole (Hz) and delay (s) where asked, then f_3dB, f_peak, peak_dB and the phases.
    """
    from accelcal.methods.response import fit_model, fit_rows
    from accelcal.methods.response.model import parse_model

    check_format(fmt)
    parse_model(model)
    at = parse_grid(phase_at, "--phase-at") if phase_at else []
    info = _lab_info(record_out, [file], serial, operator)
    result = fit_model(_reduced([file], reference, None, gaps=gaps, max_fill=max_fill), model)
    _plot(result, plot)
    _save(result, info, record_out, [file])
    emit(fit_rows(result, at), fmt, title=f"{model} fit of {file.name}")


@app.command("plan")
def plan(
    *,
    route: str = typer.Option("stepped", "--method", help="stepped or broadband."),
    snr: float = typer.Option(40.0, "--snr", help="The DUT channel's RMS signal-to-noise "
                                                  "ratio, dB (broadband: in a bin)."),
    ref_snr: float | None = typer.Option(None, "--ref-snr",
                                         help="Stepped: the reference channel's, dB "
                                              "(default: the DUT's)."),
    magnitude_u: float = typer.Option(0.1, "--magnitude-u",
                                      help="Target standard uncertainty of the magnitude, %."),
    phase_u: float = typer.Option(0.1, "--phase-u",
                                  help="Target standard uncertainty of the phase, deg."),
    frequencies: str = typer.Option("80", "--frequencies", help="Stepped: step frequencies, "
                                                                 "Hz (list or range)."),
    sample_rate: float = typer.Option(10000.0, "--sample-rate", help="Sample rate, Hz."),
    resolution: float = typer.Option(5.0, "--resolution", help="Broadband: bin width, Hz."),
    fmt: str = _FORMAT,
) -> None:
    """Periods (stepped) or Welch averages (broadband) that reach a stated uncertainty.

    Rows route,frequency_hz (the step's; broadband: the bin width),segment,averages
    (periods or segments),n_d,samples,record_s,magnitude_u_pct,phase_u_deg (reached).
    """
    from accelcal.methods.response import plan as plan_response

    check_format(fmt)
    rows = plan_response(route=route, snr_db=snr, ref_snr_db=ref_snr,
                         magnitude_u_pct=magnitude_u, phase_u_deg=phase_u,
                         frequencies=parse_grid(frequencies, "--frequencies"),
                         sample_rate=sample_rate, resolution_hz=resolution)
    emit(rows, fmt, title=f"frequency-response plan ({route}, SNR {snr:g} dB)")
