"""The centrifuge's unestimated terms: combination names, the IA-tangential sign term, Type B.

Two kinds of term move the estimates without being estimated:

- a model term the positions cannot separate (Kop beside Ko and Kio): the
  rows it enters are named after the combination they estimate, with the
  weights of the alias matrix to three digits (``Ko-Kop``, ``Kio+Kop`` when
  the rig errors are given; other weights when the proof-mass offset is
  estimated, which takes part of Kop); weights below :data:`NAME_ATOL` and
  what the rounding leaves are bounded by the term's prior (Type B);
- the asymmetry's sign at a position whose input axis is perpendicular to
  the specific force at the nominal set-up (IA tangential): the reduction
  takes ``sgn(a_i) = 0`` there (Eq. (C4) of
  :mod:`~accelcal.methods.centrifuge.core`), but a sensor misaligned on the
  arm by theta sees ``a_i = theta A``, and the model then holds
  ``s (K0' + K1' |a_i|)/2`` with ``s = +-1`` the sign, unknown unless a
  survey gives the misalignment with a certain sign (the reduction then
  models it, :mod:`~accelcal.methods.centrifuge.core`, Eq. (C4)). The term
  ``s K0'`` (g) is bounded by a two-point prior of standard uncertainty
  ``|K0'| + |K1'| theta_max A_max`` (the estimates plus two of their SDs
  when K0' and K1' are estimated, else the default priors;
  :data:`MISALIGNMENT_BOUND`), and propagated as a Type B contribution to
  every row it moves.
  It is never estimated: with the IA-tangential position the design
  absorbs it exactly (K0, K1, Kp, Kip move), so nothing separates it.

The alias matrix is that of the final weighted Gauss-Newton step, ``A =
(X' W X)^-1 X' W Z`` on the weighted design of the coefficients and the
estimated rig errors (the given rig errors' pseudo-observations left
out), converted to g/g^n as ``K_t = b_t / K1``.

References
----------
.. [IEEE836] IEEE Std 836-2009, centrifuge testing of linear accelerometers.
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021, eq. (3).
.. [GUM] JCGM 100:2008, secs. 4.3.7-4.3.9 (Type B), 5.1.2, G.4.1.
"""

import math
from dataclasses import dataclass

import numpy as np

from accelcal.aliasing import Alias, Contribution, Prior, aliases, default_priors, propagate
from accelcal.identifiability import combination_name, inseparable
from accelcal.methods.centrifuge.core import asymmetry_sign
from accelcal.model import term_unit
from accelcal.physics.centrifuge import ASYMMETRY_TERMS, FULL_TERMS, regressors

ALIAS_RTOL = 1e-3
"""A term whose column the design reproduces to this fraction of its norm is named in the
rows (:func:`accelcal.identifiability.inseparable`): Kop beside Ko and Kio stays aliased
through a misalignment of tens of microradians, which separates it only in exact arithmetic."""

NAME_ATOL = 1e-3
"""A weight below this (row unit per term unit) is left out of a combination's name."""

MISALIGNMENT_BOUND = 1e-3
"""Largest misalignment of a sensor on the arm considered, rad: at an IA-tangential
position ``|a_i| <= MISALIGNMENT_BOUND * A``, so the sign term ``s (K0' + K1' |a_i|)/2``
is bounded by ``|K0'| + |K1'| MISALIGNMENT_BOUND A_max``."""


@dataclass(frozen=True)
class Unestimated:
    """What the unestimated terms do to a centrifuge reduction (g/g^n rows, then rig errors)."""

    labels: dict
    covariance: np.ndarray
    contributions: tuple[Contribution, ...]
    aliases: tuple[Alias, ...]
    priors: tuple[Prior, ...]
    named: tuple[str, ...]


def tangential_positions(blocks, sign_at=None) -> tuple[str, ...]:
    """Positions of the centrifuge blocks whose asymmetry sign is taken as 0 (Eq. (C4)).

    Their a_i is zero at the nominal set-up and no surveyed misalignment of
    certain sign gives it one (:func:`~accelcal.methods.centrifuge.core.sign_rig`).
    """
    out = []
    for blk in blocks:
        if blk.fixed is not None:
            continue
        sign = asymmetry_sign(blk, sign_at or {})
        for k, name in enumerate(blk.position_names):
            at = blk.position == k
            if at.any() and np.all(sign[at] == 0) and name not in out:
                out.append(name)
    return tuple(out)


def sign_term(position: str) -> str:
    """Input name of the asymmetry's unknown sign at an IA-tangential position."""
    return f"K0_asym*sgn(a_i)@{position}"


def analyse_unestimated(sol, blocks, *, values, cov, output_unit: str,
                        priors="default") -> Unestimated:
    """Alias matrix, names and Type B of the unestimated terms of a centrifuge solution.

    Parameters
    ----------
    sol : accelcal.methods.centrifuge.core.Solution
    blocks : sequence of Block
    values, cov : numpy.ndarray
        The solution in g/g^n (``to_g_units``), coefficients then rig errors.
    output_unit : str
    priors : "default", "none" or None
        ``"default"``: the two-point prior of each IA-tangential sign term
        from the K0' estimate (module docs); ``"none"``/None: aliases only.

    Returns
    -------
    Unestimated
    """
    terms, p = sol.terms, len(sol.terms)
    rows_all = (*terms, *sol.estimated)
    q_terms = [t for t in (*FULL_TERMS, *ASYMMETRY_TERMS) if t not in terms]
    tangential = tangential_positions(blocks, sol.sign_at)
    cols, names = [], []
    for t in q_terms:
        cols.append(np.concatenate([regressors(*blk.forces(sol.rig), (t,),
                                               sign=asymmetry_sign(blk, sol.sign_at))[:, 0]
                                    for blk in blocks]))
        names.append(t)
    for pos in tangential:
        cols.append(np.concatenate([
            0.5 * (blk.position == blk.position_names.index(pos)) if blk.fixed is None and
            pos in blk.position_names else np.zeros(blk.y.size) for blk in blocks]))
        names.append(sign_term(pos))
    n_rows = len(rows_all)
    if not names:
        return Unestimated({}, np.zeros((n_rows, n_rows)), (), (), (), ())
    count = np.concatenate([blk.count for blk in blocks])
    var = np.concatenate([np.full(blk.y.size, s**2) for blk, s in zip(blocks, sol.sigma,
                                                                       strict=True)])
    sw = np.sqrt(count / var)
    z = np.column_stack(cols) * sw[:, None]
    # a sign term is never named: its sign is what is unknown
    named = tuple(n for n in inseparable(sol.design, z, names, rtol=ALIAS_RTOL) if "@" not in n)
    k1 = float(values[terms.index("K1")])
    est_design = sol.estimator_design
    z_full = np.vstack([z, np.zeros((est_design.shape[0] - z.shape[0], z.shape[1]))])
    # per unit (g/g^n) of each term; the given rig errors' rows are marginalised
    a_b = np.linalg.lstsq(est_design, z_full * k1, rcond=None)[0][:n_rows]
    jac = np.eye(n_rows)
    i1 = terms.index("K1")
    jac[:p, :p] /= k1
    jac[:p, i1] = -values[:p] / k1  # d(b_t / K1)/d b_1 = -K_t / K1
    jac[i1, i1] = 1.0
    a_g = jac @ a_b
    units = {t: term_unit(t, output_unit) for t in terms}
    # An inseparable term is named with its weights to 3 digits (above NAME_ATOL); what the
    # rounding leaves (a misalignment's share, ~1e-5) is bounded by the term's prior.
    shares = np.zeros_like(a_g)
    for j, z_ in enumerate(names):
        if z_ in named:
            w = np.array([float(f"{v:.3g}") for v in a_g[:, j]])
            shares[:, j] = np.where(np.abs(w) >= NAME_ATOL, w, 0.0)
    labels = {}
    for i, t in enumerate(terms):
        name = combination_name(t, {z_: shares[i, j] for j, z_ in enumerate(names)
                                    if z_ in named})
        if name != t:
            labels[t] = name
    rows = tuple(labels.get(t, t) for t in rows_all)
    row_units = {labels.get(t, t): units.get(t, "") for t in rows_all}
    rest = a_g - shares
    top = max(float(np.max(np.abs(blk.level))) for blk in blocks if blk.level is not None)
    given = _priors(tuple(names), terms, values, cov, output_unit, priors,
                    reach=MISALIGNMENT_BOUND * top)
    cov_b, parts = propagate(rest, rows, tuple(names), given, row_units=row_units)
    term_units = {z_: term_unit(z_, output_unit) if z_ in q_terms else "g" for z_ in names}
    sep = [j for j, z_ in enumerate(names) if z_ not in named]
    entries = aliases(a_g[:, sep], rows, tuple(names[j] for j in sep), row_units=row_units,
                      term_units=term_units)
    return Unestimated(labels, cov_b, parts, entries, tuple(given.values()), named)


def _priors(names, terms, values, cov, output_unit, priors, *, reach) -> dict:  # noqa: PLR0917
    """Default priors of the model terms; two-point priors of the sign terms (module docs)."""
    if priors is None or priors == "none":
        return {}
    out = default_priors([n for n in names if "@" not in n], output_unit)
    fallback = default_priors(ASYMMETRY_TERMS, output_unit)
    magnitude, source = {}, "estimate"
    for t in ASYMMETRY_TERMS:
        if t in terms:  # bounded by the reduction's own estimate
            i = terms.index(t)
            magnitude[t] = abs(float(values[i])) + 2.0 * math.sqrt(max(float(cov[i, i]), 0.0))
        else:
            magnitude[t] = fallback[t].value if t in fallback else 0.0
            source = "default"
    bound = magnitude["K0_asym"] + magnitude["K1_asym"] * reach
    for n in names:
        if "@" in n and bound > 0:
            # s = +-1 with equal odds: a two-point distribution, SD |K0'|
            out[n] = Prior(n, bound, "g", "two-point", math.inf, source)
    return out
