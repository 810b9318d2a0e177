"""The triad's unestimated terms: each axis's pendulous error terms, aliased and bounded.

The triad model (bias, scale factor, triangular non-orthogonality, optional
quadratic) leaves out the terms a pendulous accelerometer axis also has
(:mod:`accelcal.rigs.triad_axes`): K2 a_i², K3 a_i³, the cross-coupling
Kio a_i a_o, Kip a_i a_p, Kop a_o a_p, the odd-input Koo a_o², Kpp a_p²
and the asymmetry ``sgn(a_i)(K0' + K1' a_i)/2``. On static positions at
1 g they move the interval means, and so the rows: K2 g² and the odd-input
terms look like a bias, K3 g³ like a scale factor, and so on, by amounts
the positions decide.

:func:`with_type_b` takes the alias matrix by central differences of the
reduction of the interval means (two more reductions per term and axis:
ms each, on a few dozen means), with each term's change of the means per
unit term taken at the positions' specific force (known orientations:
``g up``; unknown: the calibrated means) in each axis's IA, OA, PA frame;
bounds each term by a prior (the embedded default accelerometer's, like
the tumble: twice its magnitude, rectangular) and adds ``A u² A'`` to the
covariance, itemised in ``Reduction.type_b``; terms without a prior are
listed in ``Reduction.aliases``. At a position where an axis's a_i is zero
(within :data:`ZERO_A_I`), the sign of K0'/2 there is unknown: a term
``K0_asym@<label>`` of its own, two-point.

References
----------
.. [Guan2021] Guan et al., the error model of a pendulous accelerometer, eqs. (1)-(3).
.. [Montgomery] Montgomery D. C., Design and Analysis of Experiments, 8th
   ed., Wiley, 2013, sec. 10.3 (alias matrix).
.. [GUM] JCGM 100:2008, secs. 4.3.7, 5.1.2.
"""

import dataclasses

import numpy as np

from accelcal.aliasing import aliases, default_priors, propagate
from accelcal.errors import AccelcalError
from accelcal.methods.triad.common import calibration_of
from accelcal.terms import term_unit

TERMS = ("K2", "K3", "Koo", "Kpp", "Kio", "Kip", "Kop", "K0_asym", "K1_asym")
"""Terms of each axis's pendulous error model the triad model leaves out (K4 too, but the
default accelerometer's is zero: listed only when given)."""

ZERO_A_I = 1e-4
"""|a_i| (g) below which the sign of an axis's a_i, and so that of K0'/2, is unknown."""

STEP = 1e-3
"""Perturbation of a term (g/g^n) for the central differences: the known-orientation
reduction is linear in the means, the gravity-norm one smooth (second-order error
~STEP^2 relative)."""


def with_type_b(red, means, reduce_again, *, gravity: float, up=None, priors="default",
                labels=None):
    """``red`` with each axis's unestimated pendulous terms as Type B.

    Parameters
    ----------
    red : Reduction
        A triad reduction of ``means``.
    means : array_like, shape (n, 3)
        The interval means it reduced, input unit.
    reduce_again : callable
        ``means -> Reduction``: the same reduction with the same options.
    gravity : float
        m/s^2 per g.
    up : array_like, shape (n, 3), optional
        Known orientations (fixture frame); None: the calibrated means give
        each position's specific force.
    priors : {"default", "none"}
        ``"none"``: nothing propagated, every term's aliases listed.
    labels : sequence of str, optional
        Position labels, for the ``K0_asym@`` terms (default P1...).

    Returns
    -------
    Reduction
    """
    if priors not in ("default", "none"):
        raise AccelcalError(f"priors {str(priors)[:40]!r} is not one of default, none",
                            parameter="priors")
    means = np.asarray(means, dtype=float)
    use = priors == "default"
    names, columns, pri = term_columns(red, means, gravity=gravity, up=up, labels=labels,
                                       bound=use)
    est = red.sensors[0]
    a = np.column_stack([
        (reduce_again(means + STEP * c).sensors[0].values
         - reduce_again(means - STEP * c).sensors[0].values) / (2 * STEP) for c in columns])
    rows = tuple(est.label(t) for t in est.names)
    units = {est.label(t): est.units[t] for t in est.names}
    used = {full: pri.get(full, pri.get(term)) for full, term in names
            if pri.get(full, pri.get(term)) is not None}
    used = {k: dataclasses.replace(p, name=k) for k, p in used.items()}
    full_names = tuple(full for full, _ in names)
    cov, parts = propagate(a, rows, full_names, used, row_units=units)
    free = [i for i, full in enumerate(full_names) if full not in used]
    entries = aliases(a[:, free], rows, tuple(full_names[i] for i in free), row_units=units,
                      term_units={full_names[i]: term_unit(names[i][1], "g") for i in free})
    sensor = dataclasses.replace(est, covariance=est.covariance + cov)
    covariance = red.covariance
    if covariance is not None and np.ndim(covariance) == 2 and \
            covariance.shape[0] >= cov.shape[0]:
        covariance = np.array(covariance, dtype=float)
        covariance[:cov.shape[0], :cov.shape[0]] += cov
    bounds = ", ".join(f"{p.name} +-{p.value:.3g} {p.unit}"
                       for p in default_priors(TERMS, "g").values())
    note = (f"each axis's pendulous terms the triad model leaves out ({', '.join(TERMS)}) "
            f"bounded by the embedded default priors ({bounds}; K0'/2 of unknown sign where "
            "an axis's a_i = 0) and propagated as Type B to the rows they move") if use else \
        "priors none: the pendulous terms' aliases listed, no Type B propagated"
    return dataclasses.replace(red, sensors=(sensor, *red.sensors[1:]), covariance=covariance,
                               type_b=(*red.type_b, *parts), aliases=(*red.aliases, *entries),
                               priors=(*red.priors, *used.values()),
                               notes=(*red.notes, note))


def term_columns(red, means, *, gravity: float, up=None, labels=None, bound: bool = True):
    """Every axis's unestimated terms: names, change of the means per unit term, priors.

    Parameters
    ----------
    red : Reduction
        The triad reduction (its calibration gives the axes' frames).
    means : numpy.ndarray, shape (n, 3)
    gravity : float
    up : array_like, optional
        Known orientations; None: the calibrated means give the specific force.
    labels : sequence of str, optional
    bound : bool
        Give each term its embedded default prior (and each ``K0_asym@`` one).

    Returns
    -------
    names : list of (str, str)
        ``(row name, term)``, e.g. ``("K2[x]", "K2")``.
    columns : list of numpy.ndarray, shape (n, 3)
        Input unit per unit term (g/g^n).
    priors : dict
        Row name or term -> Prior.
    """
    from accelcal.rigs.triad_axes import axis_frames

    n = means.shape[0]
    labels = list(labels) if labels is not None else [f"P{j + 1}" for j in range(n)]
    cal = calibration_of(red)
    if up is not None:
        force = gravity * np.asarray(up, dtype=float)
        if cal.rotation is not None:
            force = force @ cal.rotation
    else:
        force = cal.apply(means)
    ia, oa, pa, norm = axis_frames(cal.t)
    a_i, a_o, a_p = (force @ m.T / gravity for m in (ia, oa, pa))  # (n, 3), g
    pri = default_priors(TERMS, "g") if bound else {}
    asym = default_priors(("K0_asym",), "g").get("K0_asym")
    columns, names = [], []
    per_g = gravity * norm / cal.scale  # input unit per g of each axis's indicated error
    for i, axis in enumerate("xyz"):
        regress = _regressors(a_i[:, i], a_o[:, i], a_p[:, i])
        for term in TERMS:
            col = np.zeros((n, 3))
            col[:, i] = per_g[i] * regress[term]
            columns.append(col)
            names.append((f"{term}[{axis}]", term))
        for j in np.flatnonzero(np.abs(a_i[:, i]) < ZERO_A_I):
            name = f"K0_asym@{labels[j]}[{axis}]"
            col = np.zeros((n, 3))
            col[j, i] = 0.5 * per_g[i]
            columns.append(col)
            names.append((name, "K0_asym"))
            if bound and asym is not None:
                pri[name] = dataclasses.replace(asym, name=name)  # +-K0': still within +-a
    return names, columns, pri


def _regressors(a_i, a_o, a_p) -> dict:
    """Each term's indicated error per unit term, g, at the positions' inputs (g)."""
    return {"K2": a_i**2, "K3": a_i**3, "Koo": a_o**2, "Kpp": a_p**2, "Kio": a_i * a_o,
            "Kip": a_i * a_p, "Kop": a_o * a_p, "K0_asym": 0.5 * np.sign(a_i),
            "K1_asym": 0.5 * np.sign(a_i) * a_i}
