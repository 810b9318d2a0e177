"""``accelcal budget``: the itemised GUM budget of every reported coefficient.

The files given become reductions with their input data through
:func:`accelcal.report.budgets.gather`; the budgets are printed by
:func:`accelcal.budget.render.render_budgets` as a table, CSV or JSON.
"""

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
        "K1, K_I, K0+Kpp; a frequency response's point, S(80 Hz), gives its magnitude and "
        "phase budgets, 'S(80 Hz) phase' the one)."),
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
    from accelcal.budget.render import render_budgets
    from accelcal.report.budgets import gather

    out, warned = [], set()
    for reduction, inputs, sensors, method in gather(records, data):
        if the_lab is not None:
            _check_due(the_lab, method, allow_expired, warned)
            _warn_missing(method, the_lab)
        found = budgets(reduction, the_lab, records=inputs, model=model,
                        check={"trials": trials, "seed": seed} if check else None)
        out += [b for b in found if (sensors is None or b.sensor in sensors)
                and (coefficient is None or coefficient in (
                    b.coefficient, b.coefficient.removesuffix(" magnitude").removesuffix(
                        " phase")))]
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
