"""``accelcal budget``: the itemised GUM budget of every reported coefficient."""

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
        "warning and in the budgets' notes); without it they are refused."),
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
    the_lab = _lab(lab, allow_expired)
    from accelcal.budget import budgets
    from accelcal.budget.report import gather, render_budgets

    out = []
    for reduction, inputs, sensors, method in gather(records, data):
        if the_lab is not None:
            _warn_missing(method, the_lab)
        found = budgets(reduction, the_lab if the_lab is not None else _empty_lab(),
                        records=inputs,
                        check={"trials": trials, "seed": seed} if check else None)
        out += [b for b in found if (sensors is None or b.sensor in sensors)
                and (coefficient is None or coefficient in (b.coefficient,))]
    if coefficient is not None and not out:
        raise AccelcalError(f"--coefficient {coefficient!r}: no reported coefficient of that "
                            "name")
    sys.stdout.write(render_budgets(out, fmt))


def _lab(path: Path | None, allow_expired: bool):
    if path is None:
        return None
    from accelcal.budget.lab import load_lab

    lab = load_lab(path)
    if allow_expired:
        late = lab.expired()
        if late:
            typer.echo("warning: expired standard(s) used: " + ", ".join(
                f"{s.quantity} (due {s.due})" for s in late), err=True)
    else:
        lab.check_due()
    return lab


def _empty_lab():
    from accelcal.budget.lab import Lab, Laboratory

    return Lab(Laboratory(""), (), {}, None, {}, {}, "", Path())


def _warn_missing(method, lab) -> None:
    if method is None:
        return
    missing = [q for q in method.budget_inputs if q not in lab.standards]
    if missing:
        typer.echo(f"warning: {lab.path.name} declares no {', '.join(missing)} (inputs of the "
                   f"{method.name} model); they are not in the budget", err=True)
