"""Options and output of ``--uncertainty formal|mc`` shared by the reduction commands."""

import typer

UNCERTAINTY = typer.Option(
    "formal", "--uncertainty",
    help="formal (least-squares covariance) or mc (Monte Carlo, GUM Supplement 1: adds "
         "mc_std and the 95 % coverage interval ci95_low, ci95_high in the coefficient units; "
         "the engineering units then carry mc_std).",
)
TRIALS = typer.Option(
    10_000, "--trials",
    help="Monte Carlo trials for --uncertainty mc (> 0). Trials stream in blocks, so memory "
         "stays bounded for any count; a count estimated to take over an hour is refused "
         "with the estimate (--force runs it), a long run shows its progress.")
SEED = typer.Option(0, "--seed", help="Seed of the Monte Carlo generator (integer >= 0).")
FORCE = typer.Option(
    False, "--force",
    help="Run work estimated to take more than an hour: Monte Carlo trials (the first task "
         "is timed) or a simulation (samples x the simulator's measured cost per sample); "
         "refused otherwise, with the estimate. Memory and disk bounds still hold.")


def forced(command):
    """Run ``command`` (a command with a ``force`` parameter) inside :func:`accelcal.work.forcing`.

    The simulators check their work with :func:`accelcal.work.simulated`, which
    sees the command's ``--force`` this way; a run estimated over
    :data:`accelcal.work.PROGRESS_AFTER_S` is announced on standard error with
    its estimate.
    """
    import functools

    @functools.wraps(command)
    def run(*args, **kwargs):
        from accelcal import work

        with work.forcing(kwargs.get("force", False), announce=_announce):
            return command(*args, **kwargs)

    return run


def _announce(est) -> None:
    """Tell of a long simulation on standard error, with its estimate."""
    from accelcal.work import shown_seconds

    typer.echo(f"accelcal: progress: {est.what}: about {shown_seconds(est.seconds)} "
               f"({est.basis})", err=True)


def check(kind: str, trials: int, seed: int) -> bool:
    """Check the options; True when Monte Carlo is asked for."""
    from accelcal.uncertainty import check_options

    check_options(kind, trials, seed)
    return kind == "mc"


def relative(value: float, what: str, monte_carlo: bool) -> float:
    """A relative uncertainty given in %, as a fraction; only with ``--uncertainty mc``."""
    import math

    from accelcal.errors import AccelcalError

    if not (math.isfinite(value) and value >= 0) or (value and not monte_carlo):
        raise AccelcalError(f"{what} {value:g} must be a relative uncertainty >= 0 %, used "
                            "with --uncertainty mc")
    return value / 100


def progress_bar():
    """The progress bar of a Monte Carlo uncertainty run (shown after 2 s, on a terminal)."""
    from accelcal.cli.progress import DelayedProgress

    return DelayedProgress("Monte Carlo uncertainty")


def merge(rows: list[dict], mc) -> list[dict]:
    """Rows with the Monte Carlo columns of coefficient ``i`` added to row ``i``.

    The engineering units (``engineering``, ``eng_std``) then carry the Monte
    Carlo standard uncertainty, the one the run reports, in place of the
    formal one: each is the coefficient's ``std`` times a fixed factor
    (:func:`accelcal.engineering.engineering`), so it is ``mc_std`` times that
    factor; NaN where the formal one is 0 or undetermined and gives no factor.
    """
    return [_engineering_mc({**row, **mc.columns(i)}) for i, row in enumerate(rows)]


def _engineering_mc(row: dict) -> dict:
    import math

    if not row.get("engineering"):
        return row
    std, mc_std = row["std"], row["mc_std"]
    ratio = mc_std / std if math.isfinite(std) and std > 0 else math.nan
    items = [{**e, "std": e["std"] * ratio} for e in row["engineering"]]
    return {**row, "engineering": items, "eng_std": items[0]["std"]}
