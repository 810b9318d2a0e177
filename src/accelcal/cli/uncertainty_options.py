"""Options and output of ``--uncertainty formal|mc`` shared by the reduction commands."""

import typer

UNCERTAINTY = typer.Option(
    "formal", "--uncertainty",
    help="formal (least-squares covariance) or mc (Monte Carlo, GUM Supplement 1: adds "
         "mc_std and the 95 % coverage interval ci95_low, ci95_high in the coefficient units).",
)
TRIALS = typer.Option(
    10_000, "--trials",
    help="Monte Carlo trials for --uncertainty mc (> 0). Trials stream in blocks, so memory "
         "stays bounded for any count: a huge count is a long run with a progress bar.")
SEED = typer.Option(0, "--seed", help="Seed of the Monte Carlo generator (integer >= 0).")


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
    """Rows with the Monte Carlo columns of coefficient ``i`` added to row ``i``."""
    return [{**row, **mc.columns(i)} for i, row in enumerate(rows)]
