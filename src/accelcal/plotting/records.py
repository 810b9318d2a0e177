"""Figures of the records store: coefficient history of a serial number."""

import datetime as dt

import numpy as np

from accelcal.plotting import new_figure


def history_figure(rows: list[dict], serial: str):
    """One panel per method and coefficient: estimate with k = 2 error bars against date.

    A coefficient recorded under another name from some calibration on
    (``K_F`` then ``K_F+K_OO``, :mod:`accelcal.store.history`) is one
    panel, its plain name on the axis; a dashed line marks the change and
    each side is labelled with the name it was recorded under.

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
    from accelcal.identifiability import plain_name

    def coefficient(r):
        return r.get("coefficient") or plain_name(r["name"])

    panels = list(dict.fromkeys((r["method"], coefficient(r)) for r in rows))
    several = len({method for method, _ in panels}) > 1
    fig = new_figure(figsize=(6.4, 1.9 * len(panels) + 0.6))
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (method, name) in zip(axes, panels, strict=True):
        sel = [r for r in rows if (r["method"], coefficient(r)) == (method, name)]
        when = [dt.datetime.fromisoformat(r["date"]) for r in sel]
        est = np.array([r["estimate"] for r in sel])
        err = 2 * np.array([r["std"] for r in sel])
        ax.errorbar(when, est, yerr=np.where(np.isfinite(err), err, 0.0), fmt="o-", capsize=3)
        ax.set_ylabel(f"{name} ({sel[0]['unit']})" + (f"\n{method}" if several else ""),
                      parse_math=False)
        ax.grid(alpha=0.3)
        _mark_renamings(ax, sel, when)
    axes[0].set_title(f"Calibration history of {serial} (error bars: k = 2)", parse_math=False)
    fig.autofmt_xdate()
    return fig


def _mark_renamings(ax, sel, when) -> None:
    """A dashed line where the recorded name changes, each side labelled with its name."""
    changes = [i for i in range(1, len(sel)) if sel[i]["name"] != sel[i - 1]["name"]]
    if not changes:
        return
    ax.annotate(f"recorded as {sel[0]['name']}", (0.0, 1.0), xycoords="axes fraction",
                xytext=(3, -3), textcoords="offset points", va="top", fontsize="x-small",
                parse_math=False)
    for i in changes:
        ax.axvline(when[i], color="0.5", linestyle="--", linewidth=1)
        ax.annotate(f"recorded as {sel[i]['name']} from here", (when[i], 1.0),
                    xycoords=("data", "axes fraction"), xytext=(3, -3),
                    textcoords="offset points", va="top", fontsize="x-small", parse_math=False)
