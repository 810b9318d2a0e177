"""``accelcal noise``: Allan deviations, IEEE 952 coefficients, PSD and simulated still records.

``adev`` and ``fit`` stream the recording (bounded memory: a block of rows,
the kernels' chunks and a temporary phase file, :mod:`accelcal.methods.noise.stream`)
for the overlapping kinds; ``adev --kind adev|mdev|hdev|totdev`` reads it
whole. A gap in the time column, a NaN or empty cell, time going
backwards, a constant signal, a record too short for the taus asked or a
missing rate exit with status 2 and one line.
"""

import sys
from pathlib import Path

import typer

from accelcal.cli import input_options as io_opts
from accelcal.cli import record_options
from accelcal.cli.common import check_format, check_writable, emit, parse_grid
from accelcal.errors import AccelcalError
from accelcal.formatting import unit_squared

app = typer.Typer(
    help="Noise and stability of still recordings: Allan deviations with confidence "
         "intervals, IEEE 952 coefficients (Q, N, B, K, R), PSD, simulated records.",
    no_args_is_help=True,
)

_TAUS_HELP = ("Tau set: octave (tau0 x 2^k), decade (1, 2, 4, 10, 20, 40 ... x tau0), all "
              "(every m), or averaging times in seconds (0.1,1,10 or start:stop:step).")
_TERMS_HELP = "IEEE 952 terms to fit, comma separated, from Q,N,B,K,R."
_FORCE_HELP = ("Run a tau set estimated to take longer than 60 s (refused otherwise, with the "
               "estimate; --taus all is O(N^2)).")


def _taus(text: str):
    return text if text in ("octave", "decade", "all") else parse_grid(text, "--taus")


def _options(input_format, column, time, time_unit, rate, unit, scale, delimiter,  # noqa: PLR0917
             repair=None):
    return io_opts.input_options(input_format=input_format, column=column, time=time,
                                 time_unit=time_unit, rate=rate, unit=unit, scale=scale,
                                 delimiter=delimiter, **(repair or {}))


def _progress(what: str):
    from accelcal.cli.progress import DelayedProgress

    return DelayedProgress(what)


@app.command("adev")
def adev(
    file: Path = typer.Argument(..., help="Still recording (CSV, Parquet or noise record)."),
    *,
    input_format: str = io_opts.INPUT_FORMAT, column: str | None = io_opts.COLUMN,
    time: str | None = io_opts.TIME, time_unit: str = io_opts.TIME_UNIT,
    rate: float | None = io_opts.RATE, unit: str | None = io_opts.UNIT,
    scale: float | None = io_opts.SCALE, delimiter: str | None = io_opts.DELIMITER,
    gaps: str = io_opts.GAPS, max_fill: int = io_opts.MAX_FILL, sort: bool = io_opts.SORT,
    jitter_tol: float | None = io_opts.JITTER_TOL, resample: bool = io_opts.RESAMPLE,
    rails: str | None = io_opts.RAILS,
    kind: str = typer.Option("oadev", "--kind",
                             help="adev, oadev, mdev, hdev, ohdev or totdev (NIST SP 1065)."),
    taus: str = typer.Option("octave", "--taus", help=_TAUS_HELP),
    force: bool = typer.Option(False, "--force", help=_FORCE_HELP),
    confidence: float = typer.Option(0.683, "--confidence",
                                     help="Confidence of the intervals (0.683: one sigma)."),
    fmt: str = typer.Option("table", "--format", help="table, csv or json."),
    plot: Path | None = typer.Option(None, "--plot", help="Directory for the figure."),
) -> None:
    """Allan-family deviation per tau: terms averaged, noise exponent, interval.

    The CSV header is tau_s,n,alpha,dev,dev_low,dev_high.
    """
    from accelcal.methods.noise.stream import STREAM_KINDS, stream_deviation

    check_format(fmt)
    opts = _options(input_format, column, time, time_unit, rate, unit, scale, delimiter,
                    {"gaps": gaps, "max_fill": max_fill, "sort": sort, "jitter_tol": jitter_tol,
                     "resample": resample, "rails": rails})
    from accelcal.io.recordings.repairs import Repairs

    repairs = Repairs()
    if kind in STREAM_KINDS:
        with _progress(f"{kind} of {file.name}") as progress:
            dev, _, _ = stream_deviation(file, opts, kind=kind, taus=_taus(taus),
                                         confidence=confidence, progress=progress, force=force,
                                         repairs=repairs)
    else:
        with _progress(f"{kind} of {file.name}") as progress:
            dev = _in_memory(file, opts, kind, _taus(taus), confidence, repairs,
                             force=force, progress=progress)
    io_opts.print_repairs(repairs)
    emit(dev.rows(), fmt, title=f"{kind} of {file.name} ({dev.unit}; {confidence:.1%} intervals)")
    if plot is not None:  # before the notes: a figure that cannot be written is the one line
        from accelcal.methods.noise.figures import deviation_figure
        from accelcal.plotting import save_figure

        for p in save_figure(deviation_figure(dev), plot, f"noise_{kind}"):
            print(f"wrote {p}", file=sys.stderr)
    for note in interval_notes(dev):
        print(f"note: {note}", file=sys.stderr)


FEW_EDF = 5
"""EDF below which the chi-square interval's shape is noted as approximate."""


def interval_notes(dev) -> list[str]:
    """Where the intervals of a deviation rest on an assumption, in words (docs/noise.md)."""
    import numpy as np

    notes = []
    src = np.array(dev.alpha_source)
    carried = dev.tau[src == "carried"]
    if carried.size:
        notes.append(f"taus {carried[0]:.4g} s to {carried[-1]:.4g} s have fewer than 128 "
                     "averages: their alpha is carried from the longest identified taus, and "
                     "their intervals assume the noise type does not change there")
    few = dev.tau[np.asarray(dev.edf) < FEW_EDF]
    if few.size:
        notes.append(f"taus {few[0]:.4g} s to {few[-1]:.4g} s have fewer than {FEW_EDF} "
                     "equivalent degrees of freedom: the chi-square shape is approximate there "
                     "(the 68.3 % intervals of white FM at m = N/4 held the truth in 0.74)")
    if (src == "guessed").any():
        notes.append("no tau has 128 averages: the noise type is guessed per tau and the "
                     "intervals are not known to hold")
    if dev.kind != "mdev" and (np.asarray(dev.alpha) == 1).any():
        notes.append("flicker PM (alpha 1): these intervals are not honest (they held the "
                     "truth in 0.49-0.62 of simulated series where 0.683 was stated); MDEV's hold")
    if dev.kind == "totdev" and (np.asarray(dev.alpha) == 2).any():
        notes.append("TOTDEV of white PM: the intervals at long taus are too narrow "
                     "(docs/noise.md); use oadev")
    return notes


def _in_memory(file, opts, kind, taus, confidence, repairs, *, force=False,  # noqa: PLR0917
               progress=None):
    from accelcal.io.formats.noise import check_values
    from accelcal.io.recordings import read_recording
    from accelcal.signal.allan.deviations import deviation

    if opts.gaps == "split":
        raise AccelcalError(f"--gaps split pools oadev and ohdev over segments; {kind} needs "
                            "consecutive samples (give --kind oadev, or --gaps fill)",
                            parameter="gaps")
    rec = read_recording(file, opts, channels=1, what="still recording")
    repairs.findings.update(rec.repairs.findings)
    check_values(rec.values, 0, file.name)
    gaps = rec.gaps()
    if gaps.size:
        raise AccelcalError(f"{file.name}: a gap in the time column after data row "
                            f"{int(gaps[0]) + 1}; deviations need evenly spaced samples: split "
                            "the record at the gap", parameter="values")
    return deviation(rec.values[:, 0], rec.rate, kind=kind, taus=taus, confidence=confidence,
                     unit=rec.unit, force=force, progress=progress)


@app.command("fit")
def fit(
    file: Path = typer.Argument(..., help="Still recording (CSV, Parquet or noise record)."),
    *,
    input_format: str = io_opts.INPUT_FORMAT, column: str | None = io_opts.COLUMN,
    time: str | None = io_opts.TIME, time_unit: str = io_opts.TIME_UNIT,
    rate: float | None = io_opts.RATE, unit: str | None = io_opts.UNIT,
    scale: float | None = io_opts.SCALE, delimiter: str | None = io_opts.DELIMITER,
    gaps: str = io_opts.GAPS, max_fill: int = io_opts.MAX_FILL, sort: bool = io_opts.SORT,
    jitter_tol: float | None = io_opts.JITTER_TOL, resample: bool = io_opts.RESAMPLE,
    rails: str | None = io_opts.RAILS,
    terms: str = typer.Option("N,K", "--terms", help=_TERMS_HELP + " Default N,K: unbiased "
                              "where Q, B and R are absent; the fit's chi^2 says when more "
                              "terms are needed."),
    taus: str = typer.Option("octave", "--taus", help=_TAUS_HELP),
    force: bool = typer.Option(False, "--force", help=_FORCE_HELP),
    fmt: str = typer.Option("table", "--format", help="table or json."),
    plot: Path | None = typer.Option(None, "--plot", help="Directory for the figures."),
    record_out: Path | None = typer.Option(
        None, "--record", help="Write the calibration record (JSON) of the coefficients."),
    serial: str | None = record_options.SERIAL,
    operator: str | None = record_options.OPERATOR,
    export: str | None = typer.Option(
        None, "--export", help="Also write the IMU noise YAML of N and K: kalibr (Kalibr's "
        "imu.yaml) or ros (the same under imu0:); needs --export-out."),
    export_out: Path | None = typer.Option(None, "--export-out",
                                           help="The YAML file --export writes."),
) -> None:
    """IEEE 952 coefficients by weighted non-negative least squares on the Allan variance.

    JSON: unit, each term and <term>_std in the input unit (N unit*sqrt(s), B unit,
    K unit/sqrt(s), Q unit*s, R unit/s), navigation units in "navigation".
    """
    import json

    from accelcal.methods import noise
    from accelcal.methods.noise.fit import check_terms, coefficients

    if fmt not in ("table", "json"):
        raise AccelcalError(f"--format {fmt!r} is not one of table, json")
    names = check_terms(terms)
    _check_export(export, export_out, names)
    opts = _options(input_format, column, time, time_unit, rate, unit, scale, delimiter,
                    {"gaps": gaps, "max_fill": max_fill, "sort": sort, "jitter_tol": jitter_tol,
                     "resample": resample, "rails": rails})
    info = _lab(record_out, file, serial, operator)
    with _progress(f"fit of {file.name}") as progress:
        red = noise.reduce(file, options=opts, terms=names, taus=_taus(taus),
                           progress=progress, force=force)
    if info is not None:
        from accelcal.calibration import save_records

        for p in save_records(red.to_records(info, input_files=[file]), record_out):
            print(f"wrote {p}", file=sys.stderr)
    if plot is not None:
        for p in red.plot(plot):
            print(f"wrote {p}", file=sys.stderr)
    if export is not None:
        from accelcal.io.atomic import write_text_atomic
        from accelcal.methods.noise.export import noise_yaml

        write_text_atomic(export_out, noise_yaml(red, export))
        print(f"wrote {export_out}", file=sys.stderr)
    if fmt == "json":
        sys.stdout.write(json.dumps(coefficients(red), indent=2, allow_nan=False) + "\n")
        return
    emit([{k: v for k, v in r.items() if not k.startswith("eng")} for r in red.rows()],
         "table", title=f"IEEE 952 coefficients of {file.name}")
    nav = coefficients(red)["navigation"]
    rows = [{"term": t, **r} for t, lst in nav.items() for r in lst]
    if rows:
        emit(rows, "table", title="navigation units")
    doc = coefficients(red)
    print(f"goodness of fit: chi^2 = {doc['chi2']:.3g} on {doc['chi2_dof']} dof, Birge ratio "
          f"{doc['birge_ratio']:.3g}; "
          + ("the model describes the record" if doc["model_fits"] else
             f"the model does NOT describe the record (uncertainties x {doc['birge_ratio']:.3g})")
          + (f"; at the bound 0: {', '.join(doc['at_bound'])}" if doc["at_bound"] else ""))
    for note in red.notes:
        print(f"note: {note}")
    _print_input_repairs(red)


def _print_input_repairs(red) -> None:
    """The ``note:`` lines of what was found in the recording's time column, if anything."""
    from accelcal.io.recordings.repairs import Repairs

    found = (red.provenance or {}).get("input", {}).get("repairs")
    if found:
        io_opts.print_repairs(Repairs.from_dict(found))


def _check_export(export, export_out, names) -> None:
    """Refuse an export that cannot be written, before the record is read."""
    from accelcal.methods.noise.export import FORMATS

    if export is None and export_out is None:
        return
    if export not in FORMATS:
        raise AccelcalError(f"{export!r} is not one of {', '.join(FORMATS)}",
                            parameter="export")
    if export_out is None:
        raise AccelcalError("give the YAML file --export writes", parameter="export_out")
    if not {"N", "K"} <= set(names):
        raise AccelcalError("--export needs N and K among the terms fitted", parameter="terms")
    check_writable(export_out)


def _lab(record_out, file, serial, operator):
    """Laboratory metadata for --record: the file's (a record) or the options'."""
    if record_out is None:
        return record_options.lab_info_for(None, [file], serial=serial, operator=operator)
    from accelcal.io.recordings.sources import open_source

    if open_source(file, "auto", None).input_format == "record":
        return record_options.lab_info_for(record_out, [file], serial=serial, operator=operator)
    if serial is None:
        raise AccelcalError("--record needs --serial (the file says no serial number)",
                            parameter="serial")
    import datetime as dt

    from accelcal.io.lab_metadata import LabInfo

    return LabInfo((serial,), operator or "", dt.datetime.now(dt.UTC).isoformat(
        timespec="seconds"))


@app.command("psd")
def psd(
    file: Path = typer.Argument(..., help="Still recording (CSV, Parquet or noise record)."),
    *,
    input_format: str = io_opts.INPUT_FORMAT, column: str | None = io_opts.COLUMN,
    time: str | None = io_opts.TIME, time_unit: str = io_opts.TIME_UNIT,
    rate: float | None = io_opts.RATE, unit: str | None = io_opts.UNIT,
    scale: float | None = io_opts.SCALE, delimiter: str | None = io_opts.DELIMITER,
    gaps: str = io_opts.GAPS, max_fill: int = io_opts.MAX_FILL, sort: bool = io_opts.SORT,
    jitter_tol: float | None = io_opts.JITTER_TOL, resample: bool = io_opts.RESAMPLE,
    rails: str | None = io_opts.RAILS,
    terms: str = typer.Option("Q,N,B,K,R", "--terms", help=_TERMS_HELP + " (levels marked)"),
    fmt: str = typer.Option("table", "--format", help="table, csv or json."),
    plot: Path | None = typer.Option(None, "--plot", help="Directory for the figures."),
) -> None:
    """One-sided Welch PSD (unit^2/Hz) with the fitted IEEE 952 levels beside it."""
    import numpy as np

    from accelcal.methods.noise.fit import check_terms
    from accelcal.methods.noise.psd import levels
    from accelcal.methods.noise.stream import stream_fit

    check_format(fmt)
    opts = _options(input_format, column, time, time_unit, rate, unit, scale, delimiter,
                    {"gaps": gaps, "max_fill": max_fill, "sort": sort, "jitter_tol": jitter_tol,
                     "resample": resample, "rails": rails})
    if gaps == "split":
        raise AccelcalError("a spectrum needs consecutive samples: give --gaps fill, or "
                            "split the file at its gaps", parameter="gaps")
    with _progress(f"psd of {file.name}") as progress:
        red = stream_fit(file, opts, terms=check_terms(terms), progress=progress)
    f, p = (np.asarray(red.observations[k]) for k in ("psd_frequency", "psd"))
    keep = f > 0
    marks = levels({k: v for k, v in red.estimate.as_dict().items() if k != "bias"}, f[keep],
                   red.provenance["rate_hz"])
    rows = [{"frequency_hz": float(fk), "psd": float(pk),
             **{f"level_{t}": float(v[i]) for t, v in marks.items()}}
            for i, (fk, pk) in enumerate(zip(f[keep], p[keep], strict=True))]
    emit(rows, fmt,
         title=f"one-sided PSD of {file.name} ({unit_squared(red.provenance['unit'])}/Hz)")
    _print_input_repairs(red)
    if plot is not None:
        for path in red.plot(plot):
            print(f"wrote {path}", file=sys.stderr)


@app.command("simulate")
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Noise record to write (.parquet or CSV)."),
    white: float = typer.Option(0.0, "--N", help="White noise N, unit*sqrt(s)."),
    instability: float = typer.Option(0.0, "--B", help="Bias instability B, unit."),
    walk: float = typer.Option(0.0, "--K", help="Acceleration random walk K, unit/sqrt(s)."),
    quantisation: float = typer.Option(0.0, "--Q", help="Quantisation Q, unit*s."),
    ramp: float = typer.Option(0.0, "--R", help="Ramp R, unit/s."),
    bias: float = typer.Option(0.0, "--bias", help="Constant bias, unit."),
    rate: float = typer.Option(..., "--rate", help="Sample rate, Hz."),
    duration: float = typer.Option(..., "--duration", help="Length, s."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random generator."),
    unit: str = typer.Option("g", "--unit", help="Unit of the samples: g, m/s^2, V, mV."),
    serial: str | None = typer.Option(None, "--serial", help="Serial number written."),
    force: bool = typer.Option(
        False, "--force", help="Write a record estimated to take more than an hour (refused "
        "otherwise, with the estimate; a record larger than the free disk is always refused)."),
) -> None:
    """Write a simulated still recording with known coefficients (streamed: any length).

    Its samples (rate x duration) are estimated in time and disk space first.
    """
    from accelcal import work
    from accelcal.io.formats.noise import check_header, write_blocks
    from accelcal.rigs.noise import check_settings, simulate_blocks, truth_metadata

    check_header(rate, unit, "--rate/--unit")
    coefs = {"N": white, "B": instability, "K": walk, "Q": quantisation, "R": ramp}
    check_settings(**coefs, rate=rate, duration=duration, bias=bias)
    kind = "parquet" if out.suffix.lower() == ".parquet" else "csv"
    samples = rate * duration
    work.check(work.estimate(f"{samples:.3g} samples of {kind.upper()}", samples,
                             work.SECONDS_PER_SAMPLE_STREAMED[kind],
                             disk_per_unit=work.BYTES_PER_SAMPLE_STREAMED[kind],
                             basis="measured per sample"),
               force=force, parameter="duration", directory=out.parent,
               hint="shorten --duration or lower --rate")
    blocks = simulate_blocks(**coefs, rate=rate, duration=duration, seed=seed, bias=bias)
    meta = truth_metadata(**coefs, bias=bias, seed=seed, b_range=None)
    if serial is not None:
        meta["serial"] = serial
    with _progress(f"simulating {out.name}") as progress:
        rows = write_blocks(out, blocks, rate=rate, unit=unit, metadata=meta, progress=progress,
                            total=round(rate * duration))
    typer.echo(f"wrote {out} ({rows} samples)")


@app.command("stability")
def stability(
    serial: str = typer.Option(..., "--serial", help="Serial number of the accelerometer."),
    db: str = typer.Option(..., "--db", help="Records store (SQLite path or database URL)."),
    fmt: str = typer.Option("table", "--format", help="table, csv or json."),
) -> None:
    """Turn-on to turn-on bias repeatability beside in-run stability B (stored noise fits)."""
    from accelcal.methods.noise.stability import from_store
    from accelcal.store import Store

    check_format(fmt)
    with Store(db) as store:
        red = from_store(store, serial)
    emit(red.rows(), fmt, title=f"run-to-run stability of {serial} ({red.dof} dof)")
