"""The tumble's unestimated terms: combination names, aliases and Type B contributions.

Every term a rotation about the axis excites (:data:`FULL_TERMS`, and the
asymmetry terms K0' and K1') that the reduction does not estimate moves the
estimates by the alias matrix (:mod:`accelcal.aliasing`). For either route
the estimator is linear in the outputs, ``b = L y``, so the alias matrix of
the output-unit coefficients is the route's estimator applied to the
unestimated terms' columns (``A_b = L Z``); the coefficients in g/g^n,
``K_t = b_t / K1``, move by ``A = K1 J A_b`` with J the Jacobian of that
division (first order), per g/g^n of the term.

A term the positions cannot separate from the estimated ones (Kpp about OA,
Koo about PA: ``a_i^2 + a_p^2 = 1``) names the rows it enters
(``K0+Kpp``, ``K2-Kpp``); a term they could separate is bounded by its
prior and propagated as a Type B contribution, or, without a prior, listed
with the rows it would move per unit.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, multipoint tumble analysis.
.. [GUM] JCGM 100:2008, secs. 4.3, 5.1.2.
.. [Montgomery] Montgomery D. C., Design and Analysis of Experiments, 8th
   ed., Wiley, 2013, sec. 10.3 (alias matrix).
"""

import math

import numpy as np

from accelcal.aliasing import (
    Prior,
    Unestimated,
    aliases,
    default_priors,
    propagate,
)
from accelcal.errors import AccelcalError
from accelcal.identifiability import combination_name, inseparable
from accelcal.model import term_unit
from accelcal.physics.tumble import ASYMMETRY_TERMS, FULL_TERMS, design_matrix

PRIOR_CHOICES = ("default", "none")
"""``priors`` given as text: the embedded default accelerometer's, or none."""



def check_priors(priors, terms, output_unit: str) -> dict:
    """Priors by term from ``"default"``, ``"none"``/None or a dict of Prior or numbers.

    A number is a standard uncertainty (normal) in the term's unit, from the user.
    """
    if priors is None or (isinstance(priors, str) and priors == "none"):
        return {}
    if isinstance(priors, str):
        if priors != "default":
            raise AccelcalError(f"priors {priors[:40]!r} is not one of "
                                f"{', '.join(PRIOR_CHOICES)} or a mapping of term to prior",
                                parameter="priors")
        return default_priors(terms, output_unit)
    out = {}
    for name, p in dict(priors).items():
        if isinstance(p, Prior):
            out[name] = p
            continue
        if name not in (*FULL_TERMS["OA"], *FULL_TERMS["PA"], *ASYMMETRY_TERMS):
            raise AccelcalError(f"prior of {str(name)[:40]!r}: not a term a tumble takes as "
                                "zero", parameter="priors")
        try:
            out[name] = Prior(name, float(p), term_unit(name, output_unit), "normal")
        except (TypeError, ValueError, KeyError) as exc:
            raise AccelcalError(f"prior of {str(name)[:40]!r}: {exc}", parameter="priors") from None
    return out


def parse_priors(text: str):
    """``--priors`` text: ``default``, ``none`` or ``TERM=U,...`` (standard uncertainties)."""
    text = text.strip()
    if text in PRIOR_CHOICES:
        return text
    out = {}
    for part in text.split(","):
        name, sep, value = part.partition("=")
        try:
            out[name.strip()] = float(value) if sep else None
        except ValueError:
            out[name.strip()] = None
        if out[name.strip()] is None:
            raise AccelcalError(f"{part.strip()[:40]!r} is not TERM=U (a standard "
                                "uncertainty in the term's unit); or give default or none",
                                parameter="priors")
    return out


def parse_asymmetry(text: str):
    """``--asymmetry`` text: ``auto``, ``yes`` or ``no``."""
    choices = {"auto": "auto", "yes": True, "no": False}
    if text not in choices:
        raise AccelcalError(f"{text[:40]!r} is not one of auto, yes, no",
                            parameter="asymmetry")
    return choices[text]


def left_out(axis: str, terms) -> tuple[str, ...]:
    """Terms a rotation about ``axis`` excites that ``terms`` leaves out."""
    return tuple(t for t in (*FULL_TERMS[axis], *ASYMMETRY_TERMS) if t not in terms)


def analyse_unestimated(angles, axis: str, terms, b, estimator, *, priors: dict,
                        output_unit: str, ident) -> Unestimated:
    """Alias matrix, names and Type B contributions of the terms ``terms`` leaves out.

    Parameters
    ----------
    angles : numpy.ndarray
        Positions, rad.
    axis : {"OA", "PA"}
    terms : tuple of str
        The estimated terms (with K1).
    b : numpy.ndarray, shape (p,)
        Output-unit coefficients estimated (``b_t = K1 K_t``).
    estimator : callable
        The route's linear estimator: outputs of shape (q, N) -> b of shape (q, p).
    priors : dict
        Term -> Prior.
    output_unit : str
    ident : array_like of bool
        Which estimated terms are identified (others get no label or contribution).

    Returns
    -------
    Unestimated
    """
    out_terms = left_out(axis, terms)
    p = len(terms)
    if not out_terms:
        return Unestimated((), (), {}, np.zeros((p, p)), (), (), ())
    X = design_matrix(angles, axis, terms)
    Z = design_matrix(angles, axis, (*out_terms, "K1"))[:, :-1]  # the check wants K1
    named = inseparable(X, Z, out_terms)
    i1 = terms.index("K1")
    k1 = float(b[i1])
    a_b = np.asarray(estimator(Z.T)).T  # (p, q): b moves per unit of b_z = K1 z
    jac = np.eye(p) / k1
    jac[:, i1] = -b / k1**2
    jac[i1, i1] = 1.0
    a_g = k1 * (jac @ a_b)  # (p, q): K_t per unit of z (g/g^n)
    ident = np.asarray(ident, dtype=bool)
    a_g[~ident] = 0.0
    labels = {}
    for i, t in enumerate(terms):
        shares = {z: a_g[i, j] for j, z in enumerate(out_terms) if z in named}
        name = combination_name(t, shares)
        if name != t:
            labels[t] = name
    rows = tuple(labels.get(t, t) for t in terms)
    units = {labels.get(t, t): term_unit(t, output_unit) for t in terms}
    sep = [j for j, z in enumerate(out_terms) if z not in named]
    sep_terms = tuple(out_terms[j] for j in sep)
    used = {z: priors[z] for z in sep_terms if z in priors}
    cov, parts = propagate(a_g[:, sep], rows, sep_terms, used, row_units=units)
    entries = aliases(a_g[:, sep], rows, sep_terms, row_units=units,
                      term_units={z: term_unit(z, output_unit) for z in sep_terms})
    return Unestimated(out_terms, named, labels, cov, parts, entries, tuple(used.values()))


def type_b_text(un: Unestimated) -> str | None:
    """One sentence on the Type B part, or None when no prior was propagated."""
    if not un.priors:
        return None
    return ("terms taken as zero bounded by priors (" + ", ".join(
        f"{p.name} {'+-' if p.distribution == 'rectangular' else 'u = '}{p.value:.3g} {p.unit} "
        f"({p.source})" for p in un.priors) + "), propagated as Type B to the rows they move")


def dof_text(un: Unestimated, dof: int, given: bool) -> str | None:
    """How the degrees of freedom combine, when Type B meets Type A."""
    if not un.priors:
        return None
    finite = [p for p in un.priors if math.isfinite(p.dof)]
    return ("degrees of freedom: Welch-Satterthwaite of the Type A variance "
            f"({'noise given, infinite' if given else f'{dof} residual dof'}) and the priors' "
            f"({'infinite' if not finite else 'as stated'}); Reduction.dof_eff gives each row's")
