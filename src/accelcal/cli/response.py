"""``accelcal response``: frequency response by stepped-sine comparison, and its model.

``simulate`` writes a stepped-sine record (its reference's certificate, the
DAQ's channel mismatch and the DUT's true transfer function in its
metadata); ``reduce`` gives magnitude and phase per step with their
standard uncertainties and the deviation from the reference frequency;
``fit`` fits the transfer function and gives its parameters, the -3 dB
bandwidth, the resonance and the phase at stated frequencies. A step with
too few periods, a frequency not found in the data or a reference table
that does not cover the band exit with status 2 and one line.
"""

from pathlib import Path

import typer

from accelcal.cli.common import check_format, check_writable, emit, parse_grid

app = typer.Typer(
    help="Frequency response of an accelerometer by comparison with a reference on a shaker "
         "(ISO 16063-21): simulate stepped-sine records, reduce them to magnitude and phase, "
         "fit the transfer function.",
    no_args_is_help=True,
)

_REFERENCE = typer.Option(
    None, "--reference",
    help="The reference's certificate, a CSV table frequency_hz,magnitude,phase_deg "
         "(magnitude in V/g, phase in deg); default: the one each record states.")
_FORMAT = typer.Option("table", "--format", help="table, csv or json.")
_PLOT = typer.Option(None, "--plot", help="Directory for the Bode figure.")


@app.command("simulate")
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Response record to write (CSV or .parquet)."),
    frequencies: str = typer.Option(
        "10,20,40,80,160,315,500,630,800,1000,1250", "--frequencies",
        help="Step frequencies, Hz (list or range start:stop:step)."),
    amplitude: float = typer.Option(1.0, "--amplitude", help="Acceleration amplitude, g."),
    sample_rate: float = typer.Option(20000.0, "--sample-rate", help="Sample rate, Hz."),
    periods: int = typer.Option(20, "--periods", help="Whole periods recorded per step."),
    s0: float = typer.Option(1.3, "--s0", help="DUT static sensitivity, output unit per g."),
    fn: float = typer.Option(600.0, "--fn", help="DUT natural frequency, Hz."),
    zeta: float = typer.Option(0.6, "--zeta", help="DUT damping ratio."),
    pole: float | None = typer.Option(None, "--pole", help="DUT extra pole, Hz (none)."),
    delay: float = typer.Option(0.0, "--delay", help="DUT pure delay, s."),
    gain_ratio: float = typer.Option(1.0, "--gain-ratio",
                                     help="DAQ: DUT channel gain over the reference's."),
    daq_delay: float = typer.Option(0.0, "--daq-delay",
                                    help="DAQ: DUT channel delay behind the reference's, s."),
    distortion: str = typer.Option("0,0", "--distortion",
                                   help="Shaker's 2nd and 3rd harmonics, fractions (d2,d3)."),
    noise: float = typer.Option(1e-4, "--noise", help="White noise of each channel, V rms "
                                                      "(0: an exact record)."),
    unit: str = typer.Option("V", "--unit", help="DUT output unit: V, mV or mA."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the random generator."),
) -> None:
    """Write a simulated stepped-sine comparison (the truth in its metadata)."""
    from accelcal.errors import AccelcalError
    from accelcal.io.formats import response as response_format
    from accelcal.rigs.shaker_response import DutResponse, ResponseRig

    check_writable(out)
    dist = parse_grid(distortion, "--distortion")
    if len(dist) != 2:
        raise AccelcalError("--distortion: give two fractions, d2,d3")
    dut = DutResponse(S0=s0, fn_hz=fn, zeta=zeta, pole_hz=pole, delay_s=delay)
    rig = ResponseRig(frequencies=tuple(parse_grid(frequencies, "--frequencies")),
                      amplitudes=(amplitude,), sample_rate=sample_rate, periods=periods,
                      gain_ratio=gain_ratio, delay_s=daq_delay, distortion=tuple(dist),
                      noise=noise)
    response_format.write(out, rig.simulate(dut, seed=seed, unit=unit))
    typer.echo(f"wrote {out}")


def _reduced(files, reference, reference_frequency):
    from accelcal.methods.response import reduce as reduce_response

    return reduce_response([Path(f) for f in files], reference=reference,
                           reference_frequency=reference_frequency)


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
        help="Frequency of the deviations, Hz: the step nearest it (default 80 Hz)."),
    fmt: str = _FORMAT,
    plot: Path | None = _PLOT,
) -> None:
    """Magnitude and phase of the DUT's sensitivity at each step, with standard uncertainties.

    The CSV header is frequency_hz,magnitude,magnitude_u,phase_deg,phase_u,unit,
    deviation_pct,deviation_pct_u,deviation_db (magnitude in the output unit per g).
    """
    from accelcal.methods.response import response_rows

    check_format(fmt)
    red = _reduced(files, reference, reference_frequency)
    _plot(red, plot)
    emit(response_rows(red), fmt, title=f"frequency response ({len(files)} record(s))")


@app.command("fit")
def fit(
    file: Path = typer.Argument(..., help="Response record (kind response)."),
    *,
    model: str = typer.Option("second-order", "--model",
                              help="second-order, optionally with ,pole and ,delay."),
    reference: Path | None = _REFERENCE,
    phase_at: str = typer.Option("", "--phase-at",
                                 help="Frequencies at which to give the phase, Hz (list)."),
    fmt: str = _FORMAT,
    plot: Path | None = _PLOT,
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
    result = fit_model(_reduced([file], reference, None), model)
    _plot(result, plot)
    emit(fit_rows(result, at), fmt, title=f"{model} fit of {file.name}")
