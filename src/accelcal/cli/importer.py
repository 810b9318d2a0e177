"""``accelcal import`` and ``accelcal inspect``: a lab's DAQ recording made into a record.

``inspect`` lists what a recording holds (channels, lengths, rates, units,
properties) so that a user can write the channel map once, in a mapping
file; ``import`` converts the recording into a record file of a kind,
streamed block by block, validated by the kind's own reader before it is
moved into place (:func:`accelcal.io.recordings.convert.import_recording`).
"""

from pathlib import Path

import typer

from accelcal.catalog import kinds, listed
from accelcal.cli.common import check_format, emit
from accelcal.cli.input_options import (
    DELIMITER,
    GAPS,
    JITTER_TOL,
    MAX_FILL,
    RAILS,
    RATE,
    RESAMPLE,
    SCALE,
    SORT,
    TIME,
    UNIT,
    parse_rails,
    print_repairs,
)
from accelcal.errors import AccelcalError

_FORMAT_HELP = ("Format of the recording: auto, csv, parquet, tdms, hdf5, mat, imucal, imu_tk "
                "or record (default: the mapping file's, else auto: from the file's first "
                "bytes).")

KINDS = tuple(sorted(kinds()))
"""The record kinds (:mod:`accelcal.catalog`), as ``--kind`` lists them."""

_OPTIONS = {"columns": "channels", "units": "mapping", "scales": "mapping"}
"""Library parameters -> this command's options where they differ."""


def import_(
    files: list[Path] = typer.Argument(
        ..., help="The recording (TDMS, HDF5, MAT, CSV, Parquet ...); kind response: one or "
        "more, one step per file (or the steps detected in each, --steps detect)."),
    *,
    out: Path = typer.Option(..., "--out", help="The record file to write (.parquet for "
                             "Parquet, streamed; else CSV)."),
    channels: str | None = typer.Option(
        None, "--channels", help="Record column = channel, comma separated, e.g. "
        "acc_x=Accel/X,acc_y=Accel/Y,acc_z=Accel/Z (see `accelcal inspect`)."),
    kind: str | None = typer.Option(
        None, "--kind", help=f"Record kind: {listed(KINDS)} (default: the mapping file's)."),
    input_format: str | None = typer.Option(None, "--input-format", help=_FORMAT_HELP),
    rate: float | None = RATE,
    time: str | None = TIME,
    time_unit: str | None = typer.Option(None, "--time-unit",
                                         help="Unit of the time column: s, ms, us or ns."),
    unit: str | None = UNIT,
    scale: float | None = SCALE,
    delimiter: str | None = DELIMITER,
    gaps: str = GAPS, max_fill: int = MAX_FILL, sort: bool = SORT,
    jitter_tol: float | None = JITTER_TOL, resample: bool = RESAMPLE, rails: str | None = RAILS,
    temperature: str | None = typer.Option(
        None, "--temperature", help="Temperature channels summarised in the provenance: "
        "name = channel, comma separated (unit degC or K: the file's, or --temperature-unit)."),
    temperature_unit: str | None = typer.Option(
        None, "--temperature-unit", help="Unit of the temperature channels: degC or K."),
    serial: str | None = typer.Option(None, "--serial", help="Serial number (metadata)."),
    operator: str | None = typer.Option(None, "--operator", help="Operator (metadata)."),
    mapping: Path | None = typer.Option(
        None, "--mapping", help="A mapping file (TOML or JSON) of the DAQ layout; the options "
        "given here override it."),
    block_rows: int = typer.Option(1 << 20, "--block-rows", min=1_000, help="Samples per "
                                   "block: the memory bound (about 40 bytes per sample and "
                                   "channel)."),
    fmt: str = typer.Option("table", "--format", help="Output: table, csv or json."),
    frequencies: str | None = typer.Option(
        None, "--frequencies", help="Kind response: each file's step frequency, Hz, comma "
        "separated (default: detected, the strongest spectral line of drive, else ref)."),
    steps: str | None = typer.Option(
        None, "--steps", help="Kind response: files (one step per file, the default) or detect "
        "(the plateaus of constant frequency in each file)."),
    step_window: float | None = typer.Option(
        None, "--step-window", help="Kind response, --steps detect: the detection window, s "
        "(default 0.5)."),
    min_periods: int | None = typer.Option(
        None, "--min-periods", help="Kind response: fewest whole periods of a step (default 3; "
        "a shorter step is refused)."),
    min_coherence: float | None = typer.Option(
        None, "--min-coherence", help="Kind response: least coherence of a step (default 0.9; "
        "a step below it is flagged, the rest goes on)."),
    reference: Path | None = typer.Option(
        None, "--reference", help="Kind response: the reference's certificate, a CSV table "
        "frequency_hz,magnitude,phase_deg[,magnitude_U,phase_U], written into the record (it "
        "must cover the steps)."),
) -> None:
    """Convert a recording into an accelcal record file of a kind, validated before it appears."""
    import dataclasses

    from accelcal.cli.progress import DelayedProgress
    from accelcal.io.recordings import InputOptions
    from accelcal.io.recordings.convert import import_recording
    from accelcal.io.recordings.mapping import Mapping, load_mapping

    check_format(fmt)
    plan = load_mapping(mapping) if mapping is not None else Mapping()
    given = {"input_format": input_format, "rate": rate, "time": time, "time_unit": time_unit,
             "unit": unit, "scale": scale,
             "delimiter": "\t" if delimiter == "\\t" else delimiter,
             "gaps": gaps, "max_fill": max_fill, "sort": sort, "jitter_tol": jitter_tol,
             "resample": resample, "rails": None if rails is None else parse_rails(rails)}
    options = {**plan.options, **{k: v for k, v in given.items() if v is not None}}
    if rate is not None:
        options.pop("time", None)
    if time is not None:
        options.pop("rate", None)
    temps = _pairs(temperature, "temperature") if temperature else plan.temperature
    if temperature_unit is not None:
        options["units"] = {**options.get("units", {}),
                            **dict.fromkeys(temps.values(), temperature_unit)}
    record_map = _pairs(channels, "channels") if channels else plan.channels
    if not record_map:
        raise AccelcalError("give the channel map (--channels acc_x=Accel/X,...) or a mapping "
                            "file with a [channels] table", parameter="channels")
    kind = kind or plan.kind
    if kind is None:
        raise AccelcalError("give the record kind (--kind) or put it in the mapping file",
                            parameter="kind")
    metadata = dict(plan.metadata)
    metadata |= {k: v for k, v in (("serial", serial), ("operator", operator)) if v is not None}
    opts = InputOptions(**{k: v for k, v in options.items()
                           if k in {f.name for f in dataclasses.fields(InputOptions)}})
    response = {"--frequencies": frequencies, "--steps": steps, "--step-window": step_window,
                "--min-periods": min_periods, "--min-coherence": min_coherence,
                "--reference": reference}
    if kind == "response":
        if temps:
            raise AccelcalError("--temperature does not apply to --kind response",
                                parameter="temperature")
        _import_response(files, opts, record_map, out=out, metadata=metadata, fmt=fmt,
                         given={k: v for k, v in response.items() if v is not None})
        return
    given = [k for k, v in response.items() if v is not None]
    if given:
        raise AccelcalError(f"{given[0]} applies to --kind response only", parameter="kind")
    if len(files) != 1:
        raise AccelcalError(f"--kind {kind} imports one recording, not {len(files)}")
    file = files[0]
    try:
        with DelayedProgress(f"importing {file.name}") as progress:
            done = import_recording(file, opts, kind=kind, channels=record_map, out=out,
                                    metadata=metadata, temperature=temps, rows=block_rows,
                                    progress=progress)
    except AccelcalError as exc:  # name the options of this command
        raise AccelcalError(exc.message, parameter=_OPTIONS.get(exc.parameter, exc.parameter)
                            ) from None
    prov = done["provenance"]
    if "repairs" in prov:
        from accelcal.io.recordings.repairs import Repairs

        print_repairs(Repairs.from_dict(prov["repairs"]))
    stats = {c: v for c, v in done["statistics"].items() if c != "t"}
    row = {"record": done["record"], "kind": kind, "samples": done["samples"],
           "columns": ",".join(done["columns"]), "rate_hz": prov.get("rate_hz"),
           "source": prov["file"], "sha256": prov["sha256"]}
    if fmt == "table":
        emit([row], fmt)
        emit([{"column": c, "mean": v["mean"], "sd": v["sd"]} for c, v in stats.items()], fmt,
             title="whole-period mean and SD of one sample (record units)")
        return
    for c, v in stats.items():  # one row: the whole-period statistics as columns
        row |= {f"mean_{c}": v["mean"], f"sd_{c}": v["sd"]}
    emit([row], fmt)


def _import_response(files, opts, record_map, *, out, metadata, fmt, given) -> None:
    """``--kind response``: two-channel recordings made into a response record."""
    from accelcal.cli.common import parse_grid
    from accelcal.methods.response.importer import import_response

    settings = {"steps": given.get("--steps", "files")}
    if "--frequencies" in given:
        settings["frequencies"] = parse_grid(given["--frequencies"], "--frequencies")
    for option, name in (("--step-window", "window_s"), ("--min-periods", "min_periods"),
                         ("--min-coherence", "min_coherence")):
        if option in given:
            settings[name] = given[option]
    if "--reference" in given:
        from accelcal.methods.response import read_reference

        settings["reference"] = read_reference(given["--reference"]).to_dict()
    try:
        done = import_response(files, opts, channels=record_map, out=out, metadata=metadata,
                               **settings)
    except AccelcalError as exc:
        raise AccelcalError(exc.message, parameter={
            "window_s": "step_window"}.get(exc.parameter, exc.parameter)) from None
    rows = [{"step": k, "file": s["file"], "start_s": s["start_s"],
             "frequency_hz": s["frequency_hz"], "periods": s["periods"],
             "coherence": s["coherence"], "flagged": "yes" if s["flagged"] else ""}
            for k, s in enumerate(done["steps"])]
    if fmt == "table":
        typer.echo(f"wrote {done['record']} (kind response, {len(rows)} steps, "
                   f"{done['samples']} samples)")
    emit(rows, fmt)
    flagged = [r for r in rows if r["flagged"]]
    if flagged:
        typer.echo(f"{len(flagged)} step(s) flagged: coherence below the limit (kept; see the "
                   "record's flagged metadata)", err=True)


def _pairs(text: str, option: str) -> dict:
    """``a=b,c=d`` as a dict (a channel name keeps any '=' after the first)."""
    out = {}
    for item in text.split(","):
        col, sep, source = item.partition("=")
        if not sep or not col.strip() or not source.strip():
            raise AccelcalError(f"{item.strip()!r} is not column=channel (e.g. "
                                "acc_x=Accel/X)", parameter=option)
        if col.strip() in out:
            raise AccelcalError(f"column {col.strip()!r} is given twice", parameter=option)
        out[col.strip()] = source.strip()
    return out


def inspect(
    file: Path = typer.Argument(..., help="The recording."),
    *,
    input_format: str = typer.Option("auto", "--input-format", help=_FORMAT_HELP),
    delimiter: str | None = DELIMITER,
    fmt: str = typer.Option("table", "--format", help="Output: table, csv or json (json: "
                            "with every property)."),
) -> None:
    """List a recording's channels, lengths, rates, units and properties."""
    import json

    from accelcal.io.recordings.inventory import inventory

    check_format(fmt)
    found = inventory(file, input_format, "\t" if delimiter == "\\t" else delimiter)
    if fmt == "json":
        typer.echo(json.dumps(found, indent=2, allow_nan=False))
        return
    rows = [{"channel": c["name"], "length": c["length"], "dtype": c["dtype"] or "",
             "unit": c["unit"] or "", "rate_hz": c["rate_hz"], "start_time": c["start_time"]
             or "", "properties": _short(c["properties"])} for c in found["channels"]]
    emit(rows, fmt)
    if fmt == "table":
        typer.echo(f"{found['file']} ({found['input_format']}), sha256 {found['sha256']}")
        if found["properties"]:
            typer.echo(f"file properties: {_short(found['properties'], 600)}")


inspect.__doc__ = (f"{inspect.__doc__}\n\nThe channels are what `accelcal import` maps to the "
                   f"columns of a record of kind {listed(KINDS)} (--channels, or a mapping "
                   "file).")


def _short(props: dict, limit: int = 80) -> str:
    import json

    text = json.dumps(props, allow_nan=False) if props else ""
    return text if len(text) <= limit else text[:limit] + "..."
