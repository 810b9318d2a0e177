"""``accelcal acceptance``: acceptance tests (simulate, reduce), repeatability, compare."""

from pathlib import Path

import typer

from accelcal.cli.common import check_format, check_writable, emit
from accelcal.cli.input_options import GAPS, MAX_FILL, print_reduction_repairs
from accelcal.cli.uncertainty_options import FORCE, forced
from accelcal.errors import AccelcalError

app = typer.Typer(
    help=("Acceptance tests of pendulous accelerometers (IEEE 1293): threshold and "
          "resolution by the 50 % rule with the decision's error probability, hysteresis over "
          "the input cycle, input range and saturation, turn-on repeatability; simulated "
          "records and their reduction; repeatability over a serial's records and the shift "
          "between two; pass/fail against a specification file."),
    no_args_is_help=True,
)

_TESTS = ("threshold", "resolution", "hysteresis", "range", "turn-on", "magnetic")
_SIMULATED = (*_TESTS, "environment")


def _check_test(test: str, tests=_TESTS) -> None:
    if test not in tests:
        raise AccelcalError(f"--test {test[:20]!r} is not one of {', '.join(tests)}")


_SPEC_HELP = ("Specification file (TOML: [[limit]] quantity, lower, upper, unit): adds the "
              "limits and the decision per quantity.")
_RULE_HELP = ("Decision rule with --spec: simple or guarded (guard band w = U unless the "
              "limit gives one); default the specification's.")


@app.command("simulate")
@forced
def simulate(
    *,
    out: Path = typer.Option(..., "--out", help="Step record to write (CSV or .parquet); "
                                                "environment: OUT-before and OUT-after, "
                                                "calibration records (JSON)."),
    test: str = typer.Option("threshold", "--test",
                             help="threshold, resolution, hysteresis, range, turn-on, "
                                  "magnetic or environment."),
    set_point: float | None = typer.Option(
        None, "--set-point", help="Set-point angle, deg (default 0 for the threshold, 30 for "
                                  "the resolution)."),
    increments: str = typer.Option("0.5,1,1.5,2,3,4,6,8,12", "--increments",
                                   help="Angle increments, arcsec, ascending."),
    reversals: int = typer.Option(3, "--reversals", min=1,
                                  help="Up-and-back pairs per increment."),
    cycle_step: float = typer.Option(15.0, "--cycle-step",
                                     help="Angle step of the hysteresis cycle, deg."),
    dwell: float = typer.Option(10.0, "--dwell", help="Time at each angle, s."),
    rate: float = typer.Option(10.0, "--rate", help="Sample rate, Hz."),
    noise: float = typer.Option(5.0, "--noise", help="Output noise SD per sample, ug."),
    breakaway: float = typer.Option(10.0, "--breakaway",
                                    help="Stick-slip break-away level at null, ug."),
    friction: float = typer.Option(20.0, "--friction",
                                   help="Growth of the break-away level, ug per g of set point."),
    hysteresis: float = typer.Option(20.0, "--hysteresis",
                                     help="Decreasing-minus-increasing output far from the "
                                          "turning points, ug."),
    full_scale: float = typer.Option(50.0, "--full-scale",
                                     help="Range test: saturation input of the sensor, g."),
    rail: float = typer.Option(9.5, "--rail", min=0.0,
                               help="Range test: clipping level of the output (0.2 V/g "
                                    "sensor), V; 0 for none."),
    overload_shift: float = typer.Option(20.0, "--overload-shift",
                                         help="Range test: bias shift after the overload, ug."),
    turn_ons: int = typer.Option(8, "--turn-ons", min=1, help="Turn-on test: power cycles."),
    pairs: int = typer.Option(4, "--pairs", min=1,
                              help="Turn-on test: +1 g / -1 g dwell pairs per turn-on."),
    bias_sd: float = typer.Option(15.0, "--bias-sd",
                                  help="Turn-on test: bias SD between turn-ons, ug."),
    scale_sd: float = typer.Option(30.0, "--scale-sd",
                                   help="Turn-on test: scale-factor SD between turn-ons, ppm."),
    drift: float = typer.Option(10.0, "--drift", help="Turn-on test: in-run bias drift, ug/h."),
    shift: str = typer.Option("", "--shift", help="Environment: the coefficients' true shift, "
                                                  "e.g. K0=30ug,K1=50ppm (K1 in ppm, the "
                                                  "others in ug, mg, g or urad); none: no "
                                                  "shift."),
    serial: str = typer.Option("SN-ENV", "--serial",
                               help="Environment: serial number of the records."),
    sensitivity: str = typer.Option("20,5,8", "--sensitivity",
                                    help="Magnetic test: sensitivity along the IA, PA, OA, "
                                         "ug/mT."),
    fields: str = typer.Option("-1,-0.5,0.5,1", "--fields",
                               help="Magnetic test: field steps along each axis, mT."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the random generator."),
    force: bool = FORCE,
) -> None:
    """Write a simulated step test (its metadata: the true threshold, resolution or hysteresis)."""
    from accelcal.io.formats import acceptance as steps_format
    from accelcal.rigs.acceptance import simulate as simulate_steps

    _check_test(test, _SIMULATED)
    _finite({"--set-point": set_point, "--cycle-step": cycle_step, "--dwell": dwell,
             "--rate": rate, "--noise": noise, "--breakaway": breakaway,
             "--friction": friction, "--hysteresis": hysteresis, "--full-scale": full_scale,
             "--rail": rail, "--overload-shift": overload_shift, "--bias-sd": bias_sd,
             "--scale-sd": scale_sd, "--drift": drift})
    check_writable(out)
    if test == "environment":
        _simulate_environment(out, shift=shift, noise=noise, serial=serial, seed=seed)
        return
    try:
        ladder = tuple(float(v) for v in increments.split(","))
    except ValueError:
        raise AccelcalError(f"--increments {increments[:40]!r} is not a list of numbers "
                            "(arcsec)") from None
    if test == "range":
        from accelcal.rigs.acceptance_runs import simulate_range

        record = simulate_range(full_scale=full_scale, rail=rail or None,
                                overload_shift=overload_shift * 1e-6, dwell=dwell, rate=rate,
                                noise=noise * 1e-6 * 0.2, seed=seed)
    elif test == "magnetic":
        from accelcal.rigs.acceptance_env import simulate_magnetic

        record = simulate_magnetic(
            tuple(v * 1e-6 for v in _numbers(sensitivity, "--sensitivity", "ug/mT")),
            fields=_numbers(fields, "--fields", "mT"), dwell=dwell, rate=rate,
            noise=noise * 1e-6, seed=seed)
    elif test == "turn-on":
        from accelcal.rigs.acceptance_runs import simulate_turn_on

        record = simulate_turn_on(turn_ons=turn_ons, pairs=pairs, dwell=dwell, rate=rate,
                                  noise=noise * 1e-6, bias_sd=bias_sd * 1e-6,
                                  scale_sd=scale_sd * 1e-6, drift=drift * 1e-6, seed=seed)
    else:
        record = simulate_steps(test, set_point=set_point, increments=ladder, reversals=reversals,
                                cycle_step=cycle_step, dwell=dwell, rate=rate,
                                noise=noise * 1e-6, breakaway=breakaway * 1e-6,
                                friction=friction * 1e-6, hysteresis=hysteresis * 1e-6,
                                seed=seed)
    steps_format.write(out, record)
    typer.echo(f"wrote {out}")


def _finite(values: dict) -> None:
    """Refuse an option that is not a finite number (whichever test it is for)."""
    import math

    for option, value in values.items():
        if value is not None and not math.isfinite(value):
            raise AccelcalError(f"{option} {value:g} must be a finite number")


def _numbers(text: str, option: str, unit: str) -> tuple:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise AccelcalError(f"{option} {text[:40]!r} is not a list of numbers ({unit})") from None


def _simulate_environment(out: Path, *, shift: str, noise: float, serial: str,
                          seed: int) -> None:
    """Write the before/after calibration records of :func:`simulate_pair`."""
    from accelcal.methods.acceptance.environment import simulate_pair
    from accelcal.rigs.acceptance_env import parse_shift

    paths = [out.with_name(f"{out.stem}-{when}{out.suffix or '.json'}")
             for when in ("before", "after")]
    for path in paths:
        check_writable(path)
    pair = simulate_pair(parse_shift(shift), noise=noise * 1e-6, serial=serial, seed=seed)
    for path, record in zip(paths, pair, strict=True):
        record.save(path)
        typer.echo(f"wrote {path}")


@app.command("reduce")
def reduce(
    file: Path = typer.Argument(..., help="Step record (CSV or Parquet, kind steps)."),
    *,
    test: str | None = typer.Option(None, "--test", help="threshold, resolution, hysteresis, "
                                                         "range, turn-on or magnetic (default: "
                                                         "the record's)."),
    settle: float = typer.Option(0.0, "--settle", help="Seconds dropped at the start of each "
                                                       "dwell."),
    max_error: float = typer.Option(
        0.05, "--max-error", help="Largest probability that the 50 % decision is wrong "
                                  "accepted; above it the dwells are too short."),
    limit: float = typer.Option(1000.0, "--limit",
                                help="Range test: nonlinearity limit, ppm of the input."),
    linear_span: float | None = typer.Option(
        None, "--linear-span", help="Range test: largest |input| of the dwells the straight "
                                    "line is fitted to, g (default a third of the ladder)."),
    spec: Path | None = typer.Option(None, "--spec", help=_SPEC_HELP),
    decision_rule: str | None = typer.Option(None, "--decision-rule", help=_RULE_HELP),
    gaps: str = GAPS, max_fill: int = MAX_FILL,
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    plot: Path | None = typer.Option(None, "--plot", help="Directory for the figures."),
) -> None:
    """Reduce a step test: rows quantity, estimate, std, unit (ug for accelerations)."""
    import math

    from accelcal.io.formats import acceptance as steps_format
    from accelcal.io.recordings.repairs import with_repairs
    from accelcal.methods import acceptance

    check_format(fmt)
    if test is not None:
        _check_test(test)
    for option, value in (("--limit", limit), ("--linear-span", linear_span)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise AccelcalError(f"{option} {value:g} must be a finite number above 0")
    specification = _load_spec(spec, decision_rule)
    record = steps_format.read(file, gaps=gaps, max_fill=max_fill)
    red = with_repairs(acceptance.reduce(record, test=test, settle=settle, max_error=max_error,
                                         limit=limit * 1e-6, linear_span=linear_span),
                       record.metadata.get("repairs"))
    print_reduction_repairs(red)
    if plot is not None:
        for p in red.plot(plot):
            typer.echo(f"wrote {p}", err=True)
    rows = acceptance.quantity_rows(red)
    _emit_with_spec(rows, fmt, f"Acceptance test ({red.method}, {red.dof} dof), {file}",
                    specification, decision_rule, serial=record.metadata.get("serial"),
                    method=red.method, dof=red.dof, notes=red.estimate.notes)


def _load_spec(spec, decision_rule):
    from accelcal.conformity import RULES, load_spec

    if decision_rule is not None and decision_rule not in RULES:
        raise AccelcalError(f"--decision-rule {decision_rule[:20]!r} is not one of "
                            f"{', '.join(RULES)}")
    if spec is None:
        if decision_rule is not None:
            raise AccelcalError("--decision-rule needs --spec (the limits to decide against)")
        return None
    return load_spec(spec)


def _emit_with_spec(rows, fmt, title, specification, rule, *, serial, method, dof,
                    notes=()) -> None:
    """Emit ``rows``, with ``lower, upper, decision, risk`` per row under a specification."""
    import math
    import sys

    from accelcal.conformity import evaluate

    stream = sys.stdout if fmt == "table" else sys.stderr
    if specification is not None:
        counts = {}
        for row in rows:
            found = evaluate(specification, [row], serial=serial, method=method, rule=rule,
                             dof=dof)
            d = found[0] if found else {}
            row |= {"lower": d.get("lower", math.nan), "upper": d.get("upper", math.nan),
                    "limit_unit": d.get("unit", ""), "decision": d.get("decision", ""),
                    "risk": d.get("risk", math.nan)}
            if d:
                counts[d["decision"]] = counts.get(d["decision"], 0) + 1
        for row in rows:
            row["lower"] = math.nan if row["lower"] is None else row["lower"]
            row["upper"] = math.nan if row["upper"] is None else row["upper"]
        title += f"; specification {specification.document or specification.title}".rstrip()
    emit(rows, fmt, title=title)
    for note in notes:
        print(f"note: {note}", file=stream)
    if specification is not None:
        summary = ", ".join(f"{n} {k}" for k, n in sorted(counts.items())) or "no limit applies"
        print(f"conformity ({rule or specification.decision_rule} rule): {summary}",
              file=stream)


@app.command("compare")
def compare(
    before: Path = typer.Argument(..., help="Calibration record before the environment (JSON)."),
    after: Path = typer.Argument(..., help="Calibration record after it (JSON), same serial "
                                           "and method."),
    *,
    correlation: float = typer.Option(
        0.0, "--correlation", help="Correlation of the two calibrations' errors, in [-1, 1] "
                                   "(a shared reference or rig error); 0: independent."),
    spec: Path | None = typer.Option(None, "--spec", help=_SPEC_HELP + " The limits apply "
                                                          "to the shifts."),
    decision_rule: str | None = typer.Option(None, "--decision-rule", help=_RULE_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """The shift of each coefficient between two calibrations, E_n, z or Welch t and p."""
    from accelcal.io.calibration_record import CalibrationRecord
    from accelcal.methods.acceptance import compare as compare_records

    check_format(fmt)
    specification = _load_spec(spec, decision_rule)
    one, two = CalibrationRecord.load(before), CalibrationRecord.load(after)
    rows = compare_records(one, two, correlation=correlation)
    _emit_with_spec(rows, fmt, f"Shift from {one.date} to {two.date}, {one.serial} "
                               f"({one.method})", specification, decision_rule,
                    serial=one.serial, method=one.method, dof=None)


@app.command("repeatability")
def repeatability(
    *,
    serial: str = typer.Option(..., "--serial", help="Serial number of the accelerometer."),
    db: str | None = typer.Option(None, "--db", help="Store: an SQLite file path or a database "
                                                     "URL (default: $ACCELCAL_DB, else the "
                                                     "user's records.sqlite)."),
    method: str | None = typer.Option(None, "--method", help="Only calibrations by this "
                                                             "method."),
    spec: Path | None = typer.Option(None, "--spec", help=_SPEC_HELP),
    decision_rule: str | None = typer.Option(None, "--decision-rule", help=_RULE_HELP),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Repeatability of each coefficient over a serial's calibrations in the store."""
    from accelcal.method_ids import canonical
    from accelcal.methods.acceptance import repeatability as records_repeatability
    from accelcal.store import Store

    check_format(fmt)
    specification = _load_spec(spec, decision_rule)
    with Store(db, readonly=True) as store:
        listed = [r for r in store.calibrations(serial)
                  if method is None or canonical(r["method"]) == canonical(method)]
        records = [store.record(r["id"]) for r in listed]
    rows = records_repeatability(records)
    _emit_with_spec(rows, fmt, f"Repeatability of {serial} over {len(records)} calibrations",
                    specification, decision_rule, serial=serial, method=method, dof=None)
