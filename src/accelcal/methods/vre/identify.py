"""Identification of VRE coefficients from measured VRE over a (b, A) design.

The measured VRE of every test point is linear in the rectifying
coefficients: its design matrix is :func:`~accelcal.methods.vre.vre_columns`
(the closed forms of Guan2021 eqs. (9) and (21)). :func:`identify` fits the
chosen coefficients by least squares (weighted by the VRE uncertainties when
they are given) and returns a :class:`~accelcal.results.Reduction`. What the
design cannot separate comes from :func:`accelcal.identifiability.analyse`
(one tolerance for every method, O(n p^2) time, no n x n matrix): those
coefficients get NaN estimates, and the combinations of them the design
determines are estimated instead, from a fit restricted to the row space of
the design.

Assumption names set (``Reduction.assumptions``): ``weighting``
(``"uncertainty"`` or ``"residual"``), ``chi2_dof`` (chi^2 per degree of
freedom of a weighted fit), and those passed in (e.g.
:meth:`~accelcal.methods.vre.VreMeasurement.assumptions`: ``vre``,
``sampling``, ``scale_factor``). Observations (``Reduction.observations``):
``overload`` (n, 3) in IA/OA/PA, ``amplitude`` (n,), ``direction`` (n, 3),
``vre`` (n,) as measured (before the fixed terms are subtracted) and, when
given, ``uncertainty`` (n,), all in g.

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, Metrology & Measurement Technology 41(3),
   2021, eqs. (9), (21), (24).
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., Johns
   Hopkins, 2013, sec. 5.5 (rank-deficient least squares).
"""

import dataclasses

import numpy as np

from accelcal.aliasing import priors_of, unestimated
from accelcal.errors import AccelcalError
from accelcal.fitting import least_squares
from accelcal.identifiability import Combination, analyse
from accelcal.methods.vre.closed_form import (
    PAPER_TERMS,
    VRE_TERMS,
    _amplitude,
    _finite,
    _unit_direction,
    along_ia,
    vre_columns,
)
from accelcal.methods.vre.unestimated import type_b_text
from accelcal.model import TERMS, unknown_term_message
from accelcal.results import Assumption, Estimate, Reduction

FAMILY = "vre"
"""The method family (key of :data:`accelcal.methods.REGISTRY`)."""

METHOD = "vre/identify"
"""The reduction's name, as calibration records and the store carry it."""


def _check_terms(terms, fixed) -> tuple[tuple[str, ...], dict]:
    terms = tuple(terms)
    fixed = dict(fixed or {})
    for name in (*terms, *fixed):
        if name not in VRE_TERMS:
            if name in TERMS:
                raise AccelcalError(
                    f"{name} produces no rectification error (it averages out over a period) "
                    f"and cannot be fitted from VRE; fit some of {', '.join(VRE_TERMS)}"
                )
            raise AccelcalError(unknown_term_message(name, VRE_TERMS))
    both = sorted(set(terms) & set(fixed))
    if both:
        raise AccelcalError(f"{', '.join(both)} both fitted and fixed; give each once")
    if len(set(terms)) != len(terms) or not terms:
        raise AccelcalError("give at least one coefficient to fit, each once")
    return terms, {k: float(v) for k, v in fixed.items()}


def row_space_basis(null: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``(p, p - k)`` of the complement of a null space ``(p, k)``.

    The estimable part of a rank-deficient fit lies in this row space of the
    design [GVL]_; p is small (the coefficients), so this costs O(p^3).
    """
    p, k = null.shape
    q, _ = np.linalg.qr(np.concatenate([null, np.eye(p)], axis=1))
    return q[:, k:p]


def identify(
    overload,
    amplitude,
    vre,
    uncertainty=None,
    *,
    direction=(1.0, 0.0, 0.0),
    terms=PAPER_TERMS,
    fixed=None,
    provenance=None,
    assumptions=(),
    columns=None,
    priors="default",
) -> Reduction:
    """Least-squares identification of VRE coefficients from a (b, A) design.

    Parameters
    ----------
    overload : array_like, shape (n,) or (n, 3)
        Overload of each measurement (along IA, or a vector in IA/OA/PA), g.
    amplitude : array_like, shape (n,)
        Vibration amplitude, g.
    vre : array_like, shape (n,)
        Measured VRE, g.
    uncertainty : array_like, shape (n,), optional
        Standard uncertainty of each VRE, g. When given (all > 0) the fit is
        weighted and the covariance is ``(A' W A)^-1``; otherwise the
        residual variance scales it.
    direction : array_like, shape (3,) or (n, 3)
        Vibration direction(s) in IA/OA/PA.
    terms : sequence of str
        Coefficients to fit, from :data:`~accelcal.methods.vre.VRE_TERMS`
        (default: the paper's K2, K3, K0', K1').
    fixed : dict, optional
        Coefficients held at known values; their VRE is subtracted first.
    provenance : dict, optional
        Stored in the reduction (with ``measurements``, the number of points).
    assumptions : sequence of Assumption, optional
        Further assumptions of the measurement (e.g.
        :meth:`~accelcal.methods.vre.VreMeasurement.assumptions` of the
        runs the points come from); repeats are dropped.
    columns : dict of str to array_like, optional
        The design: VRE per unit coefficient of each fitted and fixed term
        at each point, shape (n,). Default the closed forms
        (:func:`~accelcal.methods.vre.vre_columns`, exact for integrating
        sampling); for point-sampled records pass
        :meth:`~accelcal.methods.vre.VreMeasurement.design_columns`, which
        removes the sign term's discretisation error.
    priors : "default", "none", None or dict
        What is known of the rectifying terms neither fitted nor held, which
        the fit takes as zero (:mod:`accelcal.methods.vre.unestimated`):
        ``"default"`` bounds each by twice the embedded default
        accelerometer's magnitude (rectangular); a dict maps a term to an
        :class:`~accelcal.aliasing.Prior`; ``"none"`` or None propagates
        nothing and the reduction lists, in ``aliases``, the rows each term
        would move per unit. A term the design cannot separate from the
        fitted ones is named in the rows instead (``K2+0.01*Kio``).

    Returns
    -------
    Reduction
        Family ``"vre"``, method ``"vre/identify"``, one sensor with every
        requested coefficient: NaN value and covariance for the ones the
        design cannot separate (``reduction.unidentified()``), whose
        determined combinations are in ``reduction.combinations``; the held
        coefficients in ``reduction.fixed``; the design's rank and null
        space in ``reduction.identifiability``; the priors' Type B
        contributions in ``reduction.type_b`` and in the covariance.

    Raises
    ------
    AccelcalError
        For bad input, or a design that identifies nothing.

    Notes
    -----
    A coefficient is identifiable when its unit vector lies in the row
    space of the design (it is orthogonal to the design's null space). With
    a single overload, the K2 and K3 columns (A^2/2 and 3 b A^2/2) are
    proportional: only ``K2 + 3 b K3`` is determined. With every amplitude
    at or below the overload, K0' and K1' produce no VRE at all.

    References
    ----------
    .. [1] Guan2021, eqs. (9), (21), (24) (the model fitted).
    .. [2] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed.,
       sec. 5.5 (rank-deficient least squares).
    """
    terms, fixed = _check_terms(terms, fixed)
    A = _amplitude(amplitude, "amplitude").reshape(-1)
    measured = _finite(vre, "vre").reshape(-1)
    b = _finite(overload, "overload")
    b = b.reshape(-1, 3) if b.ndim == 2 else along_ia(b.reshape(-1))
    n = A.size
    if n == 0 or b.shape[0] != n or measured.size != n:
        raise AccelcalError(
            f"overload ({b.shape[0]}), amplitude ({n}) and vre ({measured.size}) must have the "
            "same non-zero number of measurements"
        )
    given = None
    if uncertainty is not None:
        given = _finite(uncertainty, "uncertainty").reshape(-1)
        if given.size != n:
            raise AccelcalError(f"uncertainty has {given.size} values for {n} measurements")
    # noise-free data (some uncertainty 0): fall back to the residual scale
    sigma = given if given is not None and (given > 0).all() else None
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite designs refused below
        cols = (vre_columns(b, A, direction) if columns is None
                else _columns(columns, terms, fixed, n))
        y = measured - sum((fixed[k] * cols[k] for k in fixed), np.zeros(n))
    d = np.broadcast_to(_unit_direction(direction), (n, 3))
    design = np.stack([np.broadcast_to(cols[t], (n,)) for t in terms], axis=1)
    units = {t: TERMS[t].unit for t in terms}
    prov = {"measurements": n, **(provenance or {})}
    if not (np.isfinite(design).all() and np.isfinite(y).all()):
        raise AccelcalError(
            f"{METHOD}: the design or the VRE is not finite (beyond the float range): the "
            "overloads, amplitudes or fixed coefficients are not those of a physical test"
        )
    ident = analyse(design, terms, sigma=sigma, units=units)
    if ident.rank == 0:
        raise AccelcalError(
            f"{METHOD}: the design identifies none of {', '.join(terms)} (every amplitude is "
            "zero?); add amplitudes above the overload"
        )
    notes: tuple[str, ...] = ()
    if ident.rank == len(terms):
        est = least_squares(design, y, terms, units, METHOD, sigma=sigma, provenance=prov)
        combos: tuple[Combination, ...] = ()
    else:
        est, combos = _fit_deficient(design, y, terms, units, sigma, ident, prov)
        notes = ((f"{', '.join(ident.unidentifiable)}: fix some of them or add overloads, "
                  "amplitudes or directions that separate them"),)
    _check_finite(est, combos, ident)
    weighting = _weighting(est, sigma)
    out = tuple(t for t in VRE_TERMS if t not in terms and t not in fixed)
    un = unestimated(design, terms, dict(zip(out, _out_columns(
        cols, out, b=b, A=A, direction=direction, n=n), strict=True)), sigma=sigma,
        identified=[t in ident.identifiable for t in terms],
        priors=priors_of(priors, out, VRE_TERMS, "a rectifying term"))
    est = dataclasses.replace(
        est, covariance=est.covariance + un.covariance, labels=un.labels,
        notes=est.notes + tuple(t for t in (type_b_text(un),) if t))
    observations = {"overload": b, "amplitude": A, "direction": d, "vre": measured}
    if given is not None:
        observations["uncertainty"] = given
    return Reduction(
        family=FAMILY, method=METHOD, sensors=(est,),
        dof=0 if sigma is not None else est.dof,
        combinations=combos, identifiability=ident,
        assumptions=tuple(dict.fromkeys((*weighting, *assumptions))),
        fixed=fixed, observations=observations, provenance=prov, notes=notes,
        type_b=un.contributions, aliases=un.aliases, priors=un.priors,
    )


def _out_columns(cols, out, *, b, A, direction, n):
    """The closed-form VRE columns of the terms left out (given columns hold only the used)."""
    if not out:
        return []
    full = cols if all(t in cols for t in out) else vre_columns(b, A, direction)
    return [np.broadcast_to(full[t], (n,)) for t in out]



def _columns(columns, terms, fixed, n) -> dict[str, np.ndarray]:
    """Given design columns, checked: one of n finite values for every term used."""
    out = {}
    for name in (*terms, *fixed):
        if name not in columns:
            raise AccelcalError(f"no design column for {name}", parameter="columns")
        col = _finite(columns[name], "columns").reshape(-1)
        if col.size != n:
            raise AccelcalError(f"{name} has {col.size} values for {n} measurements",
                                parameter="columns")
        out[name] = col
    return out


def _check_finite(est: Estimate, combos, ident) -> None:
    """Refuse estimates or uncertainties beyond the float range (never carried as results)."""
    ok = np.array([t in ident.identifiable for t in est.names])
    numbers = [est.values[ok], est.covariance[np.ix_(ok, ok)],
               [c.value for c in combos], [c.std for c in combos]]
    if not all(np.isfinite(x).all() for x in numbers):
        raise AccelcalError(
            f"{METHOD}: the estimates or their uncertainties are not finite (beyond the float "
            "range): the VRE, overloads or amplitudes are not those of a physical test"
        )


def _weighting(est: Estimate, sigma) -> tuple[Assumption, ...]:
    if sigma is None:
        return (Assumption(
            "weighting", "residual",
            text=("unweighted least squares (the VRE points carry no uncertainty, or some "
                  "are zero); the covariance is scaled by the residual variance"),
        ),)
    out = [Assumption(
        "weighting", "uncertainty",
        text="weighted by the VRE uncertainties; covariance (A'WA)^-1, not rescaled",
    )]
    if est.dof > 0:
        # With known uncertainties the covariance is (A'WA)^-1, not rescaled:
        # chi^2/dof near 1 says the stated uncertainties fit the residuals.
        ratio = float(np.sum((est.residuals / sigma) ** 2)) / est.dof
        out.append(Assumption(
            "chi2_dof", ratio,
            text=(f"chi^2/dof = {ratio:.3g} of the weighted fit (near 1 when the stated "
                  "uncertainties fit the residuals)"),
        ))
    return tuple(out)


def _fit_deficient(design, y, terms, units, sigma, ident, prov):  # noqa: PLR0917
    """Fit the estimable part of a rank-deficient design; NaN for the rest."""
    basis = row_space_basis(ident.null_space)
    z = least_squares(design @ basis, y, [f"z{i}" for i in range(basis.shape[1])],
                      {}, METHOD, sigma=sigma)
    full_values = basis @ z.values
    full_cov = basis @ z.covariance @ basis.T
    bad = np.array([t not in ident.identifiable for t in terms])
    values, cov = full_values.copy(), full_cov.copy()
    values[bad] = np.nan
    cov[bad, :] = np.nan
    cov[:, bad] = np.nan
    combos = []
    # Combinations of the unidentifiable coefficients the data determine:
    # vectors on those coordinates orthogonal to the null space.
    for c in ident.combinations:
        w = np.zeros(len(terms))
        for name, weight in c.weights:
            w[terms.index(name)] = weight
        combos.append(Combination(c.weights, value=float(w @ full_values),
                                  std=float(np.sqrt(w @ full_cov @ w)), unit=c.unit))
    est = Estimate(names=terms, values=values, covariance=cov, units=units, method=METHOD,
                   residuals=z.residuals, dof=z.dof, provenance=prov)
    return est, tuple(combos)
