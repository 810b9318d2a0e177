"""The certificate's Bode figure, drawn from the certificate document alone.

:func:`bode_uri` draws a serial's measured frequency responses (magnitude
in the output unit per g and phase in degrees against frequency in Hz,
each point with its expanded uncertainty as a band) and the fitted model's
curve, evaluated from the parameters the document states
(:func:`accelcal.methods.response.model.evaluate`). The figure is SVG with
its text as paths (it prints the same without the fonts) and without a
date or random identifiers, so a reissued certificate is byte-identical; it
is embedded in the HTML as a ``data:`` URI, which browsers and WeasyPrint
both print.

References
----------
.. [ISO16063-21] ISO 16063-21:2003 (magnitude and phase against frequency).
"""

import base64
import io

SALT = "accelcal-certificate"
"""The SVG writer's seed of its element ids (fixed: the same figure, the same bytes)."""


def bode_uri(curves, models) -> str:
    """The Bode figure of ``curves`` (and ``models``) as a ``data:image/svg+xml`` URI."""
    import matplotlib
    import numpy as np

    from accelcal.methods.response.figures import draw_model, finish_axes
    from accelcal.methods.response.model import evaluate
    from accelcal.plotting import new_figure

    fig = new_figure(figsize=(6.3, 4.6))
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    colours = ("tab:blue", "tab:green", "tab:purple", "tab:orange")
    lo, hi = np.inf, 0.0
    for n, c in enumerate(curves):
        pts = c["points"]
        f = np.array([p["frequency_hz"] for p in pts])
        mag = np.array([p["magnitude"] for p in pts])
        u_mag = np.array([p["magnitude_U"] for p in pts])
        phase = np.unwrap(np.deg2rad([p["phase_deg"] for p in pts]))
        phase = np.rad2deg(phase)
        u_phase = np.array([p["phase_U"] for p in pts])
        colour = colours[n % len(colours)]
        ax_m.fill_between(f, mag - u_mag, mag + u_mag, color=colour, alpha=0.25, lw=0,
                          label=f"U ({c['method'].partition('/')[2]})")
        ax_m.plot(f, mag, "o", ms=3, color="k" if n == 0 else colour,
                  label=f"measured ({c['method'].partition('/')[2]})")
        ax_p.fill_between(f, phase - u_phase, phase + u_phase, color=colour, alpha=0.25, lw=0)
        ax_p.plot(f, phase, "o", ms=3, color="k" if n == 0 else colour)
        lo, hi = min(lo, f.min()), max(hi, f.max())
    unit = curves[0]["unit"] if curves else (models[0]["unit"] if models else "")
    for m in models:
        if not np.isfinite(lo):
            lo, hi = m["parameters"]["fn"] / 100.0, 2.0 * m["parameters"]["fn"]
        grid = np.geomspace(lo, hi, 300)
        names = tuple(m["parameters"])
        s = evaluate([m["parameters"][k] for k in names], names, grid)
        draw_model(ax_m, ax_p, grid, s, f"fit: {m['model']}")
    finish_axes(ax_m, ax_p, unit)
    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.hashsalt": SALT, "svg.fonttype": "path"}):
        fig.savefig(buffer, format="svg", metadata={"Date": None}, bbox_inches="tight")
    text = buffer.getvalue().encode()
    return "data:image/svg+xml;base64," + base64.b64encode(text).decode("ascii")
