"""``accelcal budget``: the itemised GUM budget of every reported coefficient.

:func:`gather` turns the files given into reductions with their input data:
calibration records through the report's road (the input files found by
name and SHA-256 and reduced again, :func:`accelcal.report.rebuild.rebuild`;
when they are not found the budget keeps the record's own numbers and the
inputs entering through the data are left out), record files of data
through their method's ``reduce`` with its default settings.
:func:`render_budgets` writes the budgets as a table, CSV or JSON.
"""

import dataclasses
import json
import math
import sys
from pathlib import Path

import typer

from accelcal.errors import AccelcalError

CHECKS = ("mc",)


def budget(
    records: list[Path] = typer.Argument(
        ..., help="Calibration records (JSON, a reduction's --record; their input files are "
        "found by name and SHA-256 as accelcal report finds them) or record files of data "
        "(CSV or Parquet of any method's kind, reduced with the method's default settings)."),
    *,
    lab: Path | None = typer.Option(
        None, "--lab", help="Lab file (TOML) declaring the standards and influence quantities "
        "(docs/budget.md; examples/lab.toml). Without it: the Type A part and the priors only."),
    allow_expired: bool = typer.Option(
        False, "--allow-expired", help="Use standards past their due date (they are named in a "
        "warning and in the budgets' notes); without it a method's input past its due date "
        "is refused."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
    check: str | None = typer.Option(
        None, "--check", help="mc: validate each budget by Monte Carlo propagation of its "
        "input distributions (JCGM 101): both 95.45 % intervals and whether the GUM one is "
        "validated at the numerical tolerance."),
    trials: int = typer.Option(1_000_000, "--trials", help="Monte Carlo trials for --check mc."),
    seed: int = typer.Option(1, "--seed", help="Seed of the Monte Carlo for --check mc."),
    coefficient: str | None = typer.Option(
        None, "--coefficient", help="Only this coefficient (as the reduction names it, e.g. "
        "K1, K_I, K0+Kpp)."),
    data: list[Path] = typer.Option(
        [], "--data", help="A directory holding the records' input files (also searched two "
        "levels deep). Repeatable."),
    model_file: Path | None = typer.Option(
        None, "--model", help="The sensor's error model file with temperature terms (e.g. "
        "accelcal thermal reduce --model-out), for the sensor temperature's sensitivity; "
        "default: the reduction's own models."),
) -> None:
    """Itemised uncertainty budgets (GUM): each reported coefficient's inputs, largest first.

    Rows: the Type A part of the reduction, each prior of an unestimated
    term, and each input of the method's measurement model that the lab
    file declares (input quantity, estimate, standard uncertainty, unit,
    distribution, sensitivity coefficient, contribution, dof, share of the
    variance); then u_c, the effective degrees of freedom, k at 95.45 % and
    U. Coefficients in their engineering units (µg, ppm, µrad, µg/g²).
    """
    from accelcal.cli.common import check_format

    check_format(fmt)
    if check is not None and check not in CHECKS:
        raise AccelcalError(f"--check {check!r} is not one of {', '.join(CHECKS)}")
    if (trials != 1_000_000 or seed != 1) and check is None:
        raise AccelcalError("--trials and --seed go with --check mc")
    if trials < 1000:
        raise AccelcalError(f"--trials {trials}: give at least 1000 trials")
    for d in data:
        if not d.is_dir():
            from accelcal.validation import shown_path

            raise AccelcalError(f"{shown_path(d)}: not a directory; give the directory "
                                "holding the records' input files", parameter="data")
    model = None
    if model_file is not None:
        from accelcal.cli.common import load_model

        model = load_model(model_file)
    the_lab = None
    if lab is not None:
        from accelcal.budget.lab import load_lab

        the_lab = load_lab(lab)
    from accelcal.budget import budgets

    out, warned = [], set()
    for reduction, inputs, sensors, method in gather(records, data):
        if the_lab is not None:
            _check_due(the_lab, method, allow_expired, warned)
            _warn_missing(method, the_lab)
        found = budgets(reduction, the_lab, records=inputs, model=model,
                        check={"trials": trials, "seed": seed} if check else None)
        out += [b for b in found if (sensors is None or b.sensor in sensors)
                and (coefficient is None or coefficient in (b.coefficient,))]
    if coefficient is not None and not out:
        raise AccelcalError(f"--coefficient {coefficient!r}: no reported coefficient of that "
                            "name")
    sys.stdout.write(render_budgets(out, fmt))


def _check_due(lab, method, allow_expired: bool, warned: set) -> None:
    """Refuse the method's inputs past their due date, or warn once when they are allowed."""
    inputs = method.budget_inputs if method is not None else ()
    if not allow_expired:
        lab.check_due(quantities=inputs)
        return
    late = [s for s in lab.expired() if s.quantity in inputs and s.quantity not in warned]
    if late:
        warned.update(s.quantity for s in late)
        typer.echo("warning: expired standard(s) used: " + ", ".join(
            f"{s.quantity} (due {s.due})" for s in late), err=True)


def _warn_missing(method, lab) -> None:
    if method is None:
        return
    missing = [q for q in method.budget_inputs if q not in lab.standards]
    if missing:
        typer.echo(f"warning: {lab.path.name} declares no {', '.join(missing)} (inputs of the "
                   f"{method.name} model); they are not in the budget", err=True)


# ------------------------------------------------------------------ inputs and outputs
COLUMNS = ("quantity", "estimate", "u", "unit", "distribution", "sensitivity", "contribution",
           "dof", "share")
"""The columns of a budget's rows (GUM's table: DOMAIN section 11)."""


def _method_of_family(family: str):
    from accelcal import catalog

    return next((m for m in catalog.METHODS if m.family == family), None)


def gather(paths, search=()):
    """``(reduction, input data, sensors or None, method descriptor)`` for the files given.

    Records of one reduction (same method, date and inputs) are taken
    together; ``sensors`` is the set of the reduction's sensors they are
    records of (None: every sensor, a data file).
    """
    from accelcal import catalog
    from accelcal.io.lab_metadata import read_metadata
    from accelcal.report.inputs import read_input

    groups: dict = {}
    for path in map(Path, paths):
        kind = None
        if path.suffix.lower() in (".csv", ".parquet"):
            try:
                kind = read_metadata(path).get("kind")
            except (AccelcalError, OSError, ValueError):
                kind = None
        if isinstance(kind, str):
            method = next((m for m in catalog.METHODS if kind in m.kinds), None)
            if method is None:
                raise AccelcalError(f"{path}: record kind {kind!r} belongs to no method")
            reduce = catalog.resolve(f"{method.package}.reduce")
            yield reduce(path), path, None, method
            continue
        item = read_input(path)
        if not hasattr(item, "method"):
            raise AccelcalError(f"{path} is a triad calibration file (model only, no "
                                "uncertainty); give its calibration record (accelcal triad "
                                "calibrate --record FILE)")
        key = (item.method, item.date, tuple(item.inputs.items()))
        groups.setdefault(key, []).append((path, item))
    for members in groups.values():
        yield _from_records(members, search)


def _from_records(members, search):
    from accelcal.report.rebuild import find_inputs, rebuild

    recs = [r for _, r in members]
    built = rebuild(recs, [p for p, _ in members], search)
    files = []
    if not built.unavailable:
        files, _ = find_inputs(recs[0], members[0][0], search)
    sensors = {k for k, r in enumerate(built.records) if r is not None}
    reduction = built.reduction
    names = [r.serial if r is not None else n
             for r, n in zip(built.records, reduction.sensor_names, strict=True)]
    if len(set(names)) == len(names):  # the budgets named by the records' serial numbers
        reduction = dataclasses.replace(reduction, sensor_names=tuple(names))
    return reduction, (files or None), sensors, _method_of_family(reduction.family)


def _cell(value, digits: int = 4) -> str:
    if isinstance(value, str):
        return value
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "n/a"
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return f"{value:.{digits}g}"


def _unit(text: str) -> str:
    from accelcal.formatting import format_unit

    if text.startswith("u") and text[1:2] in ("V", "m"):
        text = "µ" + text[1:]
    return format_unit(text) if text else ""


def render_budgets(budgets, fmt: str) -> str:
    """The budgets as ``table`` (one rich table each), ``csv`` (one line per row) or ``json``.

    JSON: a list of :meth:`Budget.as_dict`. CSV: each row with its
    budget's ``serial, coefficient, coefficient_unit, value, u_c, nu_eff,
    k, U`` in front.
    """
    if fmt == "json":
        return json.dumps([b.as_dict() for b in budgets], indent=2, allow_nan=False) + "\n"
    if fmt == "csv":
        from accelcal.cli.common import csv_text

        head = ("serial", "coefficient", "coefficient_unit", "value", "u_c", "nu_eff", "k", "U")
        rows = [(b.serial, b.coefficient, b.unit, b.estimate, b.u_c, b.nu_eff, b.k, b.U,
                 *(r.as_dict()[c] for c in COLUMNS)) for b in budgets for r in b.rows]
        names = (*head, *COLUMNS)
        return csv_text({n: [row[i] for row in rows] for i, n in enumerate(names)})
    return "".join(_table(b) for b in budgets)


def _table(b) -> str:
    import io

    from rich.console import Console
    from rich.table import Table

    unit = _unit(b.unit)
    title = f"{b.serial} {b.coefficient} = {_cell(b.estimate, 7)} {unit}"
    relative = next((n for n in b.notes if n.startswith(f"{b.coefficient} = ")), None)
    if relative is not None:  # a scale factor without a nominal: its budget in ppm of itself
        title = f"{b.serial} {relative.split(';', 1)[0]} (budget in {unit} of the estimate)"
    table = Table(title=title, show_lines=False)
    for c in COLUMNS:
        table.add_column(c, justify="left" if c in ("quantity", "unit", "distribution")
                         else "right")
    for r in b.rows:
        table.add_row(r.quantity, _cell(r.estimate, 7), _cell(r.u), _unit(r.unit),
                      r.distribution, _cell(r.sensitivity), f"{_cell(r.contribution)} {unit}",
                      _cell(r.dof, 3), f"{100 * r.share:.1f} %")
    buf = io.StringIO()
    console = Console(file=buf, width=160, force_terminal=False, color_system=None)
    console.print(table)
    nu = "inf" if not math.isfinite(b.nu_eff) else f"{b.nu_eff:.0f}"
    lines = [f"u_c = {_cell(b.u_c, 3)} {unit}, nu_eff = {nu}, k = {b.k:.3f}, "
             f"U = {_cell(b.U, 3)} {unit} (95.45 %)"
             + ("; input correlations enter u_c" if b.correlated else "")]
    if b.check is not None:
        c = b.check
        verdict = "validated" if c.validated else "NOT validated"
        lines.append(f"Monte Carlo ({c.trials} trials, {c.model} model): 95.45 % interval "
                     f"[{_cell(c.mc_low, 7)}, {_cell(c.mc_high, 7)}] {unit}; GUM "
                     f"[{_cell(c.gum_low, 7)}, {_cell(c.gum_high, 7)}]; d_low = "
                     f"{_cell(c.d_low, 2)}, d_high = {_cell(c.d_high, 2)}, delta = "
                     f"{_cell(c.delta, 2)}: GUM {verdict} (JCGM 101 sec. 8)")
    lines += [f"note: {n}" for n in b.notes]
    return buf.getvalue() + "\n".join(lines) + "\n\n"
