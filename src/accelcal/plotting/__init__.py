"""Figures (matplotlib, imported only here and lazily by callers).

Every figure is written as PNG and SVG side by side by :func:`save_figure`,
atomically, with the non-interactive Agg backend; log axes are labelled in
plain text and linear axes without offset notation (:mod:`accelcal.plotting.ticks`).
"""

from pathlib import Path


def new_figure(**kwargs):
    """A new matplotlib figure on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    from matplotlib.figure import Figure

    return Figure(**{"figsize": (6.4, 4.4), "layout": "constrained", **kwargs})


def save_figure(fig, directory, stem: str) -> list[Path]:
    """Write ``fig`` to ``directory/stem.png`` and ``.svg``; return the paths.

    The directory is created if needed. Each file is written to a temporary
    name and moved into place, so a failure leaves no partial file.

    Raises
    ------
    AccelcalError
        If the directory cannot be created.
    """
    from accelcal.errors import AccelcalError
    from accelcal.io.atomic import atomic_path
    from accelcal.plotting.ticks import no_offset, plain_log_labels

    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AccelcalError(f"cannot create the figure directory {directory}: {exc}") from None
    plain_log_labels(fig)
    no_offset(fig)
    paths = []
    for ext, extra in (("png", {"dpi": 150}), ("svg", {})):
        target = directory / f"{stem}.{ext}"
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=ext, **extra)
        paths.append(target)
    return paths
