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

from dataclasses import dataclass

import numpy as np

from accelcal.aliasing import Alias, Contribution, Prior, alias_matrix, aliases, propagate
from accelcal.identifiability import combination_name, inseparable
from accelcal.model import TERMS


@dataclass(frozen=True)
class Unestimated:
    """The terms a VRE fit takes as zero and what they do to its rows.

    Attributes
    ----------
    terms : tuple of str
        The rectifying terms neither fitted nor held that the design sees.
    named : tuple of str
        Those the design cannot separate: they are in the rows' names.
    labels : dict
        Plain name -> combination name, for the rows that estimate one.
    covariance : numpy.ndarray, shape (p, p)
        Type B covariance of the fitted rows from the priors.
    contributions : tuple of Contribution
    aliases : tuple of Alias
        Rows moved by the separable terms, row unit per term unit.
    priors : tuple of Prior
        The priors propagated.
    """

    terms: tuple[str, ...]
    named: tuple[str, ...]
    labels: dict
    covariance: np.ndarray
    contributions: tuple[Contribution, ...]
    aliases: tuple[Alias, ...]
    priors: tuple[Prior, ...]


def analyse_unestimated(design, terms, columns: dict, *, sigma, identified,
                        priors: dict) -> Unestimated:
    """Alias matrix, names and Type B contributions of the rectifying terms left out.

    Parameters
    ----------
    design : numpy.ndarray, shape (n, p)
        The fitted terms' columns, g per term unit.
    terms : tuple of str
        The fitted terms.
    columns : dict of str to numpy.ndarray
        VRE column (n,) of every term left out (neither fitted nor held).
    sigma : numpy.ndarray or None
        VRE uncertainties (the fit's weights), or None (unweighted).
    identified : array_like of bool, shape (p,)
        Which fitted terms the design identifies (others get no label or contribution).
    priors : dict
        Term -> :class:`~accelcal.aliasing.Prior`.

    Returns
    -------
    Unestimated
    """
    p = len(terms)
    seen = tuple(t for t, col in columns.items() if np.any(np.asarray(col) != 0.0))
    if not seen:
        return Unestimated((), (), {}, np.zeros((p, p)), (), (), ())
    z = np.stack([np.asarray(columns[t], dtype=float) for t in seen], axis=1)
    weights = None if sigma is None else 1.0 / np.asarray(sigma, dtype=float) ** 2
    matrix = alias_matrix(design, z, weights)  # (p, q): row per unit of each term
    matrix[~np.asarray(identified, dtype=bool)] = 0.0
    named = inseparable(design, z, seen, sigma=sigma)
    labels = {}
    for i, t in enumerate(terms):
        name = combination_name(t, {u: matrix[i, j] for j, u in enumerate(seen) if u in named})
        if name != t:
            labels[t] = name
    rows = tuple(labels.get(t, t) for t in terms)
    units = {labels.get(t, t): TERMS[t].unit for t in terms}
    sep = [j for j, u in enumerate(seen) if u not in named]
    sep_terms = tuple(seen[j] for j in sep)
    used = {u: priors[u] for u in sep_terms if u in priors}
    cov, parts = propagate(matrix[:, sep], rows, sep_terms, used, row_units=units)
    entries = aliases(matrix[:, sep], rows, sep_terms, row_units=units,
                      term_units={u: TERMS[u].unit for u in sep_terms})
    return Unestimated(seen, named, labels, cov, parts, entries, tuple(used.values()))


def type_b_text(un: Unestimated) -> str | None:
    """One sentence on the Type B part, or None when no prior was propagated."""
    if not un.priors:
        return None
    return ("rectifying terms taken as zero bounded by priors (" + ", ".join(
        f"{p.name} {'+-' if p.distribution == 'rectangular' else 'u = '}{p.value:.3g} {p.unit} "
        f"({p.source})" for p in un.priors) + "), propagated as Type B to the rows they move")
