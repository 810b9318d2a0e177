"""The VRE's unestimated terms: combination names, aliases and Type B contributions.

:func:`~accelcal.methods.vre.identify` fits some of the rectifying terms
(:data:`~accelcal.methods.vre.VRE_TERMS`) and holds others at given values;
every other rectifying term is taken as zero. Its VRE column
(:func:`~accelcal.methods.vre.vre_columns`) says whether the design sees
it: a zero column (the cross-axis terms under vibration and overload along
IA, K4 on no design) moves nothing. A term the design sees moves the
fitted rows by the alias matrix (:mod:`accelcal.aliasing`):

- a term the design cannot separate from the fitted ones (its column in
  their span, e.g. Kio = (u_o / u_i) x the K2 column for a constant
  vibration direction u tilted off IA): the rows estimate combinations,
  named by :func:`accelcal.identifiability.combination_name`;
- a term the design could separate: its prior (the user's, or the
  embedded default: twice the default accelerometer's magnitude,
  rectangular) is propagated as a Type B contribution to the rows it moves;
  without a prior the aliases state by how much per unit of the term.

References
----------
.. [1] Montgomery D. C., Design and Analysis of Experiments, 8th ed., Wiley,
   2013, sec. 10.3 (the alias matrix).
.. [2] JCGM 100:2008 (GUM), secs. 4.3.7 (rectangular bound), 5.1.2 (propagation).
"""

from accelcal.aliasing import Unestimated


def type_b_text(un: Unestimated) -> str | None:
    """One sentence on the Type B part, or None when no prior was propagated."""
    if not un.priors:
        return None
    return ("rectifying terms taken as zero bounded by priors (" + ", ".join(
        f"{p.name} {'+-' if p.distribution == 'rectangular' else 'u = '}{p.value:.3g} {p.unit} "
        f"({p.source})" for p in un.priors) + "), propagated as Type B to the rows they move")
