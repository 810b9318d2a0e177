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
MC_MODELS = ("reduction", "linear")


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
    mc_model: str = typer.Option(
        "reduction", "--mc-model", help="Model of --check mc: reduction (every trial draws "
        "every input and runs the method's reduction again; default) or linear (the budget's "
        "linearised model, y0 + sum c_i dx_i: vectorised)."),
    trials: int | None = typer.Option(
        None, "--trials", help="Monte Carlo trials for --check mc. Default: with --mc-model "
        "reduction the adaptive procedure of JCGM 101 7.9 (batches of 10^4 until the results "
        "are stable at the numerical tolerance, at most 5 10^4 reductions); with linear 10^6."),
    seed: int = typer.Option(1, "--seed", help="Seed of the Monte Carlo for --check mc (the "
                             "result does not depend on --workers)."),
    workers: int | None = typer.Option(
        None, "--workers", help="Run --mc-model reduction on a local Dask cluster of this "
        "many worker processes (needs the dask extra of accelcal)."),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Run --mc-model reduction on an existing Dask scheduler, "
        "e.g. tcp://host:8786."),
    timeout: float = typer.Option(
        10.0, "--timeout", help="Seconds to wait for --scheduler to answer before giving up, s."),
    force: bool = typer.Option(
        False, "--force", help="Run a --mc-model reduction check estimated to take more than "
        "10 minutes (a few reductions are timed; refused otherwise, with the estimate)."),
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
    from accelcal.montecarlo import check_parallel

    check_parallel(workers, scheduler, timeout)
    if check is None and (trials is not None or seed != 1 or mc_model != "reduction"
                          or workers is not None or scheduler is not None or force):
        raise AccelcalError("--trials, --seed, --mc-model, --workers, --scheduler and --force "
                            "go with --check mc")
    if mc_model not in MC_MODELS:
        raise AccelcalError(f"--mc-model {mc_model!r} is not one of {', '.join(MC_MODELS)}")
    least = 1000 if mc_model == "linear" else 100
    if trials is not None and trials < least:
        raise AccelcalError(f"--trials {trials}: give at least {least} trials")
    if mc_model == "linear" and (workers is not None or scheduler is not None or force):
        raise AccelcalError("--workers, --scheduler and --force go with --mc-model reduction "
                            "(the linearised model is vectorised)")
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
    from accelcal.budget import model_inputs
    from accelcal.budget.render import render_budgets
    from accelcal.report.budgets import gather

    options = {"model": mc_model, "trials": trials, "seed": seed}
    if mc_model == "reduction":
        options.update(workers=workers, scheduler=scheduler, timeout=timeout, force=force)
    out, warned = [], set()
    for reduction, inputs, sensors, method in gather(records, data):
        if the_lab is not None:
            quantities = model_inputs(reduction)
            _check_due(the_lab, quantities, allow_expired, warned)
            _warn_missing(method.name if method is not None and quantities == method.budget_inputs
                          else reduction.method, quantities, the_lab)
        found = _budgets(reduction, the_lab, inputs, model, options if check else None)
        out += [b for b in found if (sensors is None or b.sensor in sensors)
                and (coefficient is None or coefficient in (
                    b.coefficient, b.coefficient.removesuffix(" magnitude").removesuffix(
                        " phase")))]
    if coefficient is not None and not out:
        raise AccelcalError(f"--coefficient {coefficient!r}: no reported coefficient of that "
                            "name")
    sys.stdout.write(render_budgets(out, fmt))


def _budgets(reduction, lab, inputs, model, options):
    """The budgets of one reduction, a full-model check with a progress bar."""
    from accelcal.budget import budgets

    if options is None or options["model"] == "linear":
        return budgets(reduction, lab, records=inputs, model=model, check=options)
    from accelcal.cli.progress import DelayedProgress

    with DelayedProgress("Monte Carlo of the full model") as progress:
        return budgets(reduction, lab, records=inputs, model=model,
                       check={**options, "progress": progress})


def _check_due(lab, inputs, allow_expired: bool, warned: set) -> None:
    """Refuse the model's inputs past their due date, or warn once when they are allowed."""
    if not allow_expired:
        lab.check_due(quantities=inputs)
        return
    late = [s for s in lab.expired() if s.quantity in inputs and s.quantity not in warned]
    if late:
        warned.update(s.quantity for s in late)
        typer.echo("warning: expired standard(s) used: " + ", ".join(
            f"{s.quantity} (due {s.due})" for s in late), err=True)


def _warn_missing(model: str, inputs, lab) -> None:
    """Warn of the ``model``'s inputs the lab file does not declare."""
    missing = [q for q in inputs if q not in lab.standards]
    if missing:
        typer.echo(f"warning: {lab.path.name} declares no {', '.join(missing)} (inputs of the "
                   f"{model} model); they are not in the budget", err=True)
