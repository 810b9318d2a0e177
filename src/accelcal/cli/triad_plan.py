"""``accelcal triad plan``: what a position set determines, and how well, before the test."""

from pathlib import Path

import typer

from accelcal.cli.common import check_format, emit
from accelcal.errors import AccelcalError

MAX_POSITIONS = 100_000
"""Most positions a plan takes (the design is 3 rows per position)."""


def _directions(positions: str, seed: int):
    import numpy as np

    from accelcal.io.limits import load_json, read_bounded
    from accelcal.rigs.triad import random_directions, six_positions
    from accelcal.validation import shown, shown_name

    text = positions.strip()
    if text == "six":
        return six_positions()
    if text.isdigit():
        n = int(text)
        if not 1 <= n <= MAX_POSITIONS:
            raise AccelcalError(f"{n} must be a number of positions in 1..{MAX_POSITIONS}",
                                parameter="positions")
        return random_directions(n, np.random.default_rng(seed))
    path = Path(positions)
    try:
        text = read_bounded(path, 1 << 22, "positions file").decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise AccelcalError(
            f"{shown(positions)} is not six, a number of positions, or a readable JSON file "
            f"of up vectors ({getattr(exc, 'strerror', None) or exc.__class__.__name__})",
            parameter="positions") from None
    items = load_json(text, f"positions file {shown_name(path.name)}")
    if not isinstance(items, list) or not items or len(items) > MAX_POSITIONS:
        raise AccelcalError("must be six, a number, or a JSON list of up vectors [x, y, z] "
                            '(or {"up": [x, y, z]})', parameter="positions")
    up = [item.get("up") if isinstance(item, dict) else item for item in items]
    try:
        arr = np.array(up, dtype=float)
    except (TypeError, ValueError):
        arr = np.empty(0)
    norms = np.linalg.norm(arr, axis=1) if arr.ndim == 2 and arr.shape[1:] == (3,) else None
    if norms is None or not np.isfinite(arr).all() or not (norms > 0).all():
        raise AccelcalError("must list non-zero up vectors [x, y, z]", parameter="positions")
    return arr / norms[:, None]


def plan(
    *,
    positions: str = typer.Option(
        "six", "--positions",
        help="six (the Ferraris positions), a number of random orientations, or a JSON file "
             "listing the up vectors [x, y, z] of the positions."),
    route: str = typer.Option(
        "known", "--orientations",
        help="known (turntable, indexing head, six positions) or unknown (gravity norm)."),
    quadratic: bool = typer.Option(False, "--quadratic", help="Include the quadratic terms."),
    noise: float | None = typer.Option(
        None, "--noise", help="Noise SD of one sample per axis (m/s^2), to predict the "
                              "uncertainties."),
    samples: int = typer.Option(
        500, "--samples", help="Samples averaged per position (dwell x rate), with --noise."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random orientations."),
    fmt: str = typer.Option("table", "--format", help="Output format: table, csv or json."),
) -> None:
    """Say what a position set determines, and how well, before the test.

    Rank, condition number and the directions no position visits; with
    --noise, the standard uncertainties the calibration will state.
    """
    import json
    import math

    from accelcal.methods.triad import plan as make_plan

    check_format(fmt)
    if route not in ("known", "unknown"):
        raise AccelcalError(f"{route[:40]!r} must be known or unknown", parameter="orientations")
    up = _directions(positions, seed)
    result = make_plan(up, route=route, quadratic=quadratic)
    ident = result.identifiability
    sd = result.predicted_sd(noise, samples) if noise is not None and result.ok else {}
    rows = [{"parameter": name, "determined": name in ident.identifiable,
             "predicted_sd": sd.get(name)} for name in ident.names]
    if fmt == "json":
        typer.echo(json.dumps({
            "orientations": route, "positions": result.positions, "rank": ident.rank,
            "unknowns": len(ident.names),
            "condition_number": (ident.condition_number
                                 if math.isfinite(ident.condition_number) else None),
            "missing_directions": list(result.missing), "noise_sd": noise,
            "samples": samples if noise is not None else None, "parameters": rows}, indent=2))
        return
    if fmt == "table":
        typer.echo(f"{result.positions} positions, {route} orientations: rank {ident.rank} of "
                   f"{len(ident.names)}, condition number {ident.condition_number:.3g}"
                   + (f"; no position near {', '.join(result.missing)}" if result.missing
                      else ""))
    emit(rows, fmt, title="Triad test plan")
