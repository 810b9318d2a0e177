"""Figures of the records store: coefficient history of a serial number."""

import datetime as dt

import numpy as np

from accelcal.plotting import new_figure


def history_figure(rows: list[dict], serial: str):
    """One panel per method and coefficient: estimate with k = 2 error bars against date.

    Parameters
    ----------
    rows : list of dict
        :meth:`accelcal.store.Store.history` rows.
    serial : str
        Serial number, for the title.

    Notes
    -----
    Serial numbers, coefficient names, units and methods come from records
    and are drawn as plain text (``parse_math=False``): a ``$`` in them is
    not read as mathematics.
    """
    panels = list(dict.fromkeys((r["method"], r["name"]) for r in rows))
    several = len({method for method, _ in panels}) > 1
    fig = new_figure(figsize=(6.4, 1.9 * len(panels) + 0.6))
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (method, name) in zip(axes, panels, strict=True):
        sel = [r for r in rows if (r["method"], r["name"]) == (method, name)]
        when = [dt.datetime.fromisoformat(r["date"]) for r in sel]
        est = np.array([r["estimate"] for r in sel])
        err = 2 * np.array([r["std"] for r in sel])
        ax.errorbar(when, est, yerr=np.where(np.isfinite(err), err, 0.0), fmt="o-", capsize=3)
        ax.set_ylabel(f"{name} ({sel[0]['unit']})" + (f"\n{method}" if several else ""),
                      parse_math=False)
        ax.grid(alpha=0.3)
    axes[0].set_title(f"Calibration history of {serial} (error bars: k = 2)", parse_math=False)
    fig.autofmt_xdate()
    return fig
