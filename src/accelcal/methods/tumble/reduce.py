"""Reduction of a multipoint tumble: Fourier relations or least squares, with covariance.

:func:`reduce_tumble` reduces one record to a
:class:`~accelcal.results.Reduction`; :func:`tumble_arrays` reduces many
simulated trials at once (leading axes of the outputs) to plain arrays, for
Monte Carlo checks. Both estimate the output-unit coefficients
``b_t = K1 K_t`` (by the IEEE Fourier relations for uniform sets of eight or
more positions, by least squares otherwise) and give ``K_t = b_t / K1`` in
g/g^n with first-order covariance propagation.

Assumptions set (names for code, see docs/tumble.md): ``route``,
``rotation_axis``, ``noise`` (``"given"`` or ``"residuals"``),
``noise_sd`` (output unit), ``repeats``, ``terms_taken_zero``,
``cross_nonlinearity`` and ``few_dof`` (the residual degrees of freedom, when
the noise comes from fewer than :data:`accelcal.calibration.FEW_DOF` of them)
where they apply. ``Reduction.dof`` is the degrees of freedom of the noise
variance estimate (0 when ``sigma`` is given); every Estimate's ``dof`` is the
residual degrees of freedom. Observations: ``angles`` (rad),
``outputs`` (averaged, output unit), ``fitted`` (output unit) and, for
uniform positions, ``harmonics`` (k), ``fourier_A`` and ``fourier_B``.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
.. [DOMAIN] accelcal domain notes, section 5 (corrected where docs/errata.md
   says so).
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.5.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import Combination
from accelcal.methods.tumble.fourier import (
    FourierCoefficients,
    fourier_coefficients,
    fourier_solution,
)
from accelcal.methods.tumble.identify import (
    IdentifiabilityReport,
    identifiability,
    output_unit_name,
    report_of,
)
from accelcal.methods.tumble.unestimated import (
    analyse_unestimated,
    check_priors,
    dof_text,
    left_out,
    type_b_text,
)
from accelcal.model import ErrorModel, term_unit
from accelcal.physics.tumble import (
    ASYMMETRY_TERMS,
    DEFAULT_TERMS,
    check_angles,
    check_axis,
    check_outputs,
    check_terms,
    design_matrix,
)
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.units import OUTPUT_UNITS

ROUTES = ("auto", "fourier", "lsq")
"""Reduction routes (see :func:`reduce_tumble`)."""

ASYMMETRY = ("auto", True, False)
"""Whether the least-squares route estimates K0' and K1' (see :func:`reduce_tumble`)."""


@dataclass(frozen=True)
class TumbleArrays:
    """Tumble reductions of many trials at once (:func:`tumble_arrays`).

    Attributes
    ----------
    names : tuple of str
        Term names, in the order of the last axis of ``values``.
    units : dict
        Unit of each term.
    route : {"fourier", "lsq"}
        How the estimates were computed.
    values : numpy.ndarray
        Shape ``(..., p)``: K1 in output unit per g, the others in g/g^n;
        NaN where not identifiable.
    covariance : numpy.ndarray
        Shape ``(..., p, p)``; NaN rows and columns for unidentifiable terms.
    residuals : numpy.ndarray
        Shape ``(..., N)``, observed minus fitted, output unit.
    sigma : numpy.ndarray
        Shape ``(...)``: the noise SD per (averaged) position used for the
        covariance, output unit (estimated from the residuals unless given).
    dof : int
        Residual degrees of freedom (N minus the rank).
    """

    names: tuple[str, ...]
    units: dict
    route: str
    values: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    dof: int

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties, shape ``(..., p)``."""
        return np.sqrt(np.diagonal(self.covariance, axis1=-2, axis2=-1))


@dataclass(frozen=True)
class _Solution:
    """Everything one call computes (batched over leading axes)."""

    axis: str
    terms: tuple[str, ...]
    angles: np.ndarray
    outputs: np.ndarray
    report: IdentifiabilityReport
    fourier: FourierCoefficients | None
    route: str
    b: np.ndarray
    cov_b: np.ndarray
    values: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    dof: int
    n_rep: int
    k1_ok: bool
    estimator: object


def reduce_tumble(
    angles_rad,
    outputs,
    *,
    rotation_axis: str = "OA",
    output_unit: str = "V",
    terms=None,
    route: str = "auto",
    sigma=None,
    repeats: bool = False,
    asymmetry="auto",
    priors="default",
) -> Reduction:
    """Reduce a multipoint tumble record to the model's coefficients, with covariance.

    Parameters
    ----------
    angles_rad : array_like, shape (N,)
        Positions theta_j, rad, distinct modulo 2 pi.
    outputs : array_like, shape (N,) or (N, R) with ``repeats``
        Outputs in ``output_unit`` (one record; for many trials at once use
        :func:`tumble_arrays`).
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about (see
        :func:`~accelcal.methods.tumble.specific_force`).
    output_unit : {"V", "mV", "mA", "g"}
        Unit of the outputs (K1 is then in output_unit/g).
    terms : sequence of str, optional
        Terms to estimate (must include K1); terms left out are taken as
        zero, and the assumptions say so. Default
        :data:`~accelcal.methods.tumble.DEFAULT_TERMS` of the axis.
    route : {"auto", "fourier", "lsq"}
        ``"fourier"``: the IEEE relations between A_k, B_k and the
        coefficients (needs N >= 8 uniform positions and the default
        terms); ``"lsq"``: least squares on the design; ``"auto"``: Fourier
        when it applies, else least squares. Both give the same numbers
        where both apply.
    sigma : float, optional
        Known noise SD of one reading, output unit. Without it the noise is
        estimated from the residuals (needs N greater than the rank).
    repeats : bool
        When True the last axis of ``outputs`` holds R repeated readings at
        each position; they are averaged.
    asymmetry : {"auto", True, False}
        Whether the least-squares route estimates the asymmetry terms K0'
        and K1' (``K0_asym``, ``K1_asym``) beside ``terms``: ``"auto"`` when
        ``terms`` is not given and the positions separate them with a
        degree of freedom to spare; True requires it (an error where the
        positions cannot); False never. The Fourier route never estimates
        them (they are not in the IEEE relations): they are bounded by
        ``priors`` instead.
    priors : "default", "none", None or dict
        Priors of the terms taken as zero that the positions could separate
        (:mod:`accelcal.aliasing`): ``"default"`` bounds each by twice the
        embedded default accelerometer's magnitude (rectangular); a dict
        maps a term to a :class:`~accelcal.aliasing.Prior` or to a standard
        uncertainty in its unit; ``"none"`` or None propagates nothing and
        the reduction lists, in ``aliases``, the rows each term would move
        per unit.

    Returns
    -------
    accelcal.results.Reduction
        Family ``"tumble"``, method ``"tumble/fourier"`` or ``"tumble/lsq"``;
        one sensor. A row that estimates a combination the positions cannot
        separate is named after it (``K0+Kpp``, ``K2-Kpp`` about OA;
        ``K0+Koo``, ``K2-Koo`` about PA; ``Estimate.labels``); the Type B
        contributions of the priors are in ``type_b`` and in the covariance.
        Terms that the positions cannot separate are NaN (value and
        covariance); the identifiable combinations of them are in
        ``combinations`` (weights on the output-unit coefficients, named
        ``K1`` for K1 and ``K1*Kt`` for ``K1 K_t``; unit the output unit).
        ``models`` holds the ErrorModel of the estimated terms when K1 is
        identified. Assumption and observation names: see the module docs.

    Raises
    ------
    AccelcalError
        Fewer positions than terms, duplicated angles, non-finite outputs,
        mismatched shapes or leading trial axes, no degrees of freedom
        without ``sigma``, a route that does not apply, or a bad axis, term
        or unit.

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5 (the
       Fourier relations, checked and extended to rotation about PA).
    .. [2] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.5.

    Examples
    --------
    >>> import numpy as np
    >>> from accelcal import ErrorModel
    >>> from accelcal.methods.tumble import specific_force
    >>> theta = np.arange(24) * 2 * np.pi / 24
    >>> truth = ErrorModel(K0=1e-4, K1=1.2, K2=2e-5, K3=-3e-6, Kp=5e-5)
    >>> a_i, a_o, a_p = specific_force(theta, "OA")
    >>> res = reduce_tumble(theta, truth.output(a_i, a_o, a_p) + 1e-9 * np.cos(7 * theta))
    >>> round(res.estimate["K2"] / 2e-5, 6), res.method
    (1.0, 'tumble/fourier')
    """
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite results refused in _solve
        sol = _solve(angles_rad, outputs, rotation_axis=rotation_axis, output_unit=output_unit,
                     terms=terms, route=route, sigma=sigma, repeats=repeats, single=True,
                     asymmetry=asymmetry)
    return _reduction(sol, output_unit, given=sigma is not None,
                      priors=check_priors(priors, left_out(sol.axis, sol.terms), output_unit))


def _few_dof(sol: _Solution, given: bool) -> Assumption | None:
    """Assumption ``few_dof`` when the noise SD comes from few residual dof, else None.

    Fewer than :data:`accelcal.calibration.FEW_DOF` (10): the SD's relative
    uncertainty ``1/sqrt(2 dof)`` is over 22 % and the coverage factor
    (Student's t, GUM G.3) well above 2.
    """
    from accelcal.calibration import COVERAGE_PROBABILITY, FEW_DOF, coverage_factor

    if given or sol.dof >= FEW_DOF:
        return None
    return Assumption("few_dof", int(sol.dof), "", (
        f"noise SD estimated from only {sol.dof} degree(s) of freedom (fewer than {FEW_DOF}): "
        "the standard uncertainties are themselves uncertain; an interval of "
        f"{100 * COVERAGE_PROBABILITY:g} % needs k = {coverage_factor(sol.dof):.3g} "
        "(Student's t), not 2; measure more positions or repeats, or give the noise SD"))


def tumble_arrays(
    angles_rad,
    outputs,
    *,
    rotation_axis: str = "OA",
    output_unit: str = "V",
    terms=None,
    route: str = "auto",
    sigma=None,
    repeats: bool = False,
    asymmetry=False,
) -> TumbleArrays:
    """:func:`reduce_tumble` of many trials at once, as arrays.

    Parameters are those of :func:`reduce_tumble`, except that ``outputs``
    may have leading trial axes: shape ``(..., N)`` (``(..., N, R)`` with
    ``repeats``). Each trial is reduced exactly as :func:`reduce_tumble`
    reduces it alone, without the priors' Type B part (the Monte Carlo
    draws the terms themselves). ``asymmetry`` is that of
    :func:`reduce_tumble`, default False here (the terms of the Fourier
    relations on every route).

    Returns
    -------
    TumbleArrays

    References
    ----------
    .. [1] IEEE1293, multipoint tumble analysis; DOMAIN section 5.
    """
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite results refused in _solve
        sol = _solve(angles_rad, outputs, rotation_axis=rotation_axis, output_unit=output_unit,
                     terms=terms, route=route, sigma=sigma, repeats=repeats, single=False,
                     asymmetry=asymmetry)
    return TumbleArrays(
        names=sol.terms, units={t: term_unit(t, output_unit) for t in sol.terms},
        route=sol.route, values=sol.values, covariance=sol.covariance,
        residuals=sol.residuals, sigma=sol.sigma, dof=sol.dof,
    )


def _solve(angles_rad, outputs, *, rotation_axis, output_unit, terms, route, sigma, repeats,
           single, asymmetry) -> _Solution:
    axis = check_axis(rotation_axis)
    if output_unit not in OUTPUT_UNITS:
        raise AccelcalError(f"output_unit {output_unit!r} is not one of {', '.join(OUTPUT_UNITS)}")
    if route not in ROUTES:
        raise AccelcalError(f"route {route!r} is not one of {', '.join(ROUTES)}",
                            parameter="route")
    if not any(asymmetry is a for a in ASYMMETRY) and asymmetry != "auto":
        raise AccelcalError("asymmetry must be 'auto', True or False", parameter="asymmetry")
    angles = check_angles(angles_rad)
    chosen = terms is not None
    terms = check_terms(terms, axis, DEFAULT_TERMS[axis])
    n, p = angles.size, len(terms)
    y = np.asarray(outputs, dtype=float)
    n_rep = 1
    if repeats:
        if y.ndim < 2 or y.shape[-2] != n:
            raise AccelcalError(
                f"with repeats, outputs must have shape (..., {n}, R) for {n} positions; "
                f"got {y.shape}"
            )
        n_rep = y.shape[-1]
        check_outputs(y.reshape(*y.shape[:-2], -1), n * n_rep)
        y = y.mean(axis=-1)
    y = check_outputs(y, n)
    if single and y.ndim != 1:
        raise AccelcalError(
            f"outputs of shape {np.shape(outputs)} hold {y.shape[:-1]} trials; reduce_tumble "
            "reduces one record: use tumble_arrays for many trials at once"
        )
    if n < p:
        report = identifiability(angles, axis, terms=terms)
        raise AccelcalError(
            f"{n} positions cannot determine {p} unknowns ({', '.join(terms)}); these "
            f"positions identify at most {report.rank}: use terms={list(report.suggested_terms)} "
            "or more positions"
        )
    if sigma is not None:
        sigma = float(sigma)
        if not np.isfinite(sigma) or sigma <= 0:
            raise AccelcalError(f"sigma = {sigma} must be a positive finite noise SD (output unit)",
                                parameter="sigma")
    D = design_matrix(angles, axis, terms)
    report = report_of(D, angles, axis, terms)
    dof = n - report.rank
    if dof == 0 and sigma is None:
        raise AccelcalError(
            f"{n} positions and {report.rank} identifiable combinations leave no degrees of "
            "freedom to estimate the noise; give sigma (noise SD, output unit) or more positions"
        )
    fourier_ok = (
        report.uniform and n >= 8 and report.full_rank and set(terms) == set(DEFAULT_TERMS[axis])
    )
    if route == "fourier" and not fourier_ok:
        raise AccelcalError(
            "the Fourier route needs at least 8 equally spaced positions that separate the "
            f"default terms {', '.join(DEFAULT_TERMS[axis])}; use route='lsq'",
            parameter="route",
        )
    use_fourier = fourier_ok and route in ("auto", "fourier") and asymmetry is not True
    if not use_fourier and asymmetry is not False and not set(ASYMMETRY_TERMS) & set(terms):
        extended = _with_asymmetry(angles, axis, terms, n, sigma, required=asymmetry is True,
                                   chosen=chosen)
        if extended is not None:
            terms, D, report = extended
            dof = n - report.rank
    fc = fourier_coefficients(angles, y) if report.uniform else None
    sigma_mean = None if sigma is None else sigma / np.sqrt(n_rep)
    if use_fourier:
        b, cov_unit, resid = fourier_solution(angles, y, fc, axis=axis, terms=terms)

        def estimator(z, terms=terms):
            return fourier_solution(angles, z, fourier_coefficients(angles, z), axis=axis,
                                    terms=terms)[0]
    else:
        b, cov_unit, resid = _lsq_solution(D, y, report.rank)

        def estimator(z, D=D, rank=report.rank):
            return _lsq_solution(D, z, rank)[0]
    s_hat = _noise(resid, dof, sigma_mean)
    cov_b = s_hat[..., None, None] ** 2 * cov_unit
    k1 = b[..., terms.index("K1")]
    floor = 1e-10 * np.max(np.abs(y), axis=-1)  # rounding level of the outputs, x 1e6
    if "K1" in report.identifiable and not np.all(np.abs(k1) > floor):
        raise AccelcalError(
            "the scale factor K1 estimated from these outputs is 0 (no response to the "
            "input axis): check the outputs column and the rotation axis"
        )
    values, cov = _to_g_units(b, cov_b, terms)
    k1_ok = "K1" in report.identifiable
    ident = np.array([t in report.identifiable for t in terms]) & k1_ok
    values = np.where(ident, values, np.nan)
    cov = np.where(ident[:, None] & ident[None, :], cov, np.nan)
    if not (np.isfinite(values[..., ident]).all() and np.isfinite(cov[..., ident, :]
                                                                   [..., ident]).all()):
        raise AccelcalError(
            "the estimates or their uncertainties are not finite (beyond the float range): the "
            "outputs' magnitudes are not those of an accelerometer; check the outputs column"
        )
    return _Solution(
        axis=axis, terms=terms, angles=angles, outputs=y, report=report, fourier=fc,
        route="fourier" if use_fourier else "lsq", b=b, cov_b=cov_b, values=values,
        covariance=cov, residuals=resid, sigma=s_hat, dof=dof, n_rep=n_rep, k1_ok=k1_ok,
        estimator=estimator,
    )


def _with_asymmetry(angles, axis, terms, n, sigma, *, required, chosen):
    """``terms`` with K0' and K1' when the positions separate them, else None.

    With ``required`` False, only where the user chose no terms and one
    residual degree of freedom is left (or the noise is given).
    """
    if not required and chosen:
        return None
    ext = (*terms, *ASYMMETRY_TERMS)
    D = design_matrix(angles, axis, ext)
    report = report_of(D, angles, axis, ext)
    separated = all(t in report.identifiable for t in ASYMMETRY_TERMS)
    spare = n - report.rank >= (0 if sigma is not None else 1)
    if separated and spare:
        return ext, D, report
    if required:
        raise AccelcalError(
            f"these {n} positions cannot separate the asymmetry terms K0' and K1' from "
            f"{', '.join(terms)} with a degree of freedom left; use asymmetry=False (they are "
            "then bounded by their priors) or more positions", parameter="asymmetry")
    return None


def _lsq_solution(D, y, rank):
    """Minimum-norm least squares (unique on the estimable functionals) by thin SVD."""
    u, s, vt = np.linalg.svd(D, full_matrices=False)
    ur, sr, vr = u[:, :rank], s[:rank], vt[:rank].T
    pinv = vr @ (ur / sr).T  # (p, N)
    b = y @ pinv.T
    resid = y - b @ D.T
    cov_unit = (vr / sr**2) @ vr.T
    return b, cov_unit, resid


def _noise(resid, dof, sigma):
    if sigma is not None:
        return np.full(resid.shape[:-1], sigma)
    return np.sqrt(np.sum(resid**2, axis=-1) / dof)


def _to_g_units(b, cov_b, terms):
    """K_t = b_t / K1 with first-order covariance propagation."""
    i1 = terms.index("K1")
    k1 = b[..., i1]
    p = len(terms)
    values = b / k1[..., None]
    values[..., i1] = k1
    jac = np.zeros((*b.shape[:-1], p, p))
    diag = np.broadcast_to((1.0 / k1)[..., None], b.shape).copy()
    diag[..., i1] = 1.0
    jac[..., np.arange(p), np.arange(p)] = diag
    col = -b / k1[..., None] ** 2
    col[..., i1] = 1.0
    jac[..., :, i1] = col
    cov = np.einsum("...ij,...jk,...lk->...il", jac, cov_b, jac)
    return values, cov


# ------------------------------------------------------------- the Reduction
def _reduction(sol: _Solution, output_unit: str, *, given: bool, priors: dict) -> Reduction:
    terms, report = sol.terms, sol.report
    method = f"tumble/{sol.route}"
    units = {t: term_unit(t, output_unit) for t in terms}
    few = _few_dof(sol, given)
    ident = np.isfinite(sol.values)
    un = (analyse_unestimated(sol.angles, sol.axis, terms, sol.b, sol.estimator, priors=priors,
                              output_unit=output_unit, ident=ident) if sol.k1_ok else None)
    extra = () if un is None else tuple(
        t for t in (type_b_text(un), dof_text(un, sol.dof, given)) if t)
    est = Estimate(
        names=terms, values=sol.values,
        covariance=sol.covariance + (0.0 if un is None else un.covariance),
        units=units, method=method, residuals=sol.residuals, dof=sol.dof,
        notes=_notes(sol) + ((few.text,) if few is not None else ()) + extra,
        provenance={"rotation_axis": sol.axis, "positions": int(sol.angles.size),
                    "route": sol.route},
        labels={} if un is None else un.labels,
    )
    combinations = []
    for c in report.combinations:
        w = np.zeros(len(terms))
        for t, v in c.weights:
            w[terms.index(t)] = v
        combinations.append(Combination(
            weights=tuple((output_unit_name(t), v) for t, v in c.weights),
            value=float(sol.b @ w), std=float(np.sqrt(w @ sol.cov_b @ w)),
            unit=output_unit, sensor=0,
        ))
    observations = {"angles": sol.angles, "outputs": sol.outputs,
                    "fitted": sol.outputs - sol.residuals}
    if sol.fourier is not None:
        observations |= {"harmonics": np.asarray(sol.fourier.k, dtype=float),
                         "fourier_A": sol.fourier.A, "fourier_B": sol.fourier.B}
    model = None
    if sol.k1_ok:
        finite = {t: float(v) for t, v in zip(terms, sol.values, strict=True) if np.isfinite(v)}
        model = ErrorModel.from_terms(finite, output_unit=output_unit)
    return Reduction(
        family="tumble", method=method, sensors=(est,), dof=0 if given else sol.dof,
        combinations=tuple(combinations), identifiability=report.analysis,
        assumptions=_assumptions(sol, output_unit, given=given), observations=observations,
        models=(model,),
        provenance={"rotation_axis": sol.axis, "positions": int(sol.angles.size),
                    "route": sol.route, "terms": list(terms), "repeats": sol.n_rep,
                    "output_unit": output_unit},
        type_b=() if un is None else un.contributions,
        aliases=() if un is None else un.aliases,
        priors=() if un is None else un.priors,
    )


def _left_out(sol: _Solution) -> list[str]:
    return list(left_out(sol.axis, sol.terms))


def _cross_text(sol: _Solution) -> str | None:
    cross = "Kpp" if sol.axis == "OA" else "Koo"
    if cross in _left_out(sol) and {"K0", "K2"} <= set(sol.terms):
        return (f"{cross} is not separable from K0 and K2 by a rotation about {sol.axis}: "
                f"K0 stands for K0 + {cross} and K2 for K2 - {cross}")
    return None


_FOURIER_TEXT = "Fourier route: IEEE 1293 relations as corrected in docs/errata.md"


def _repeats_text(n_rep: int) -> str:
    return f"{n_rep} repeated readings averaged at each position" if n_rep > 1 else ""


def _notes(sol: _Solution) -> tuple[str, ...]:
    """The estimate's notes (for people), as the reduction has always written them."""
    notes = []
    left_out = _left_out(sol)
    if left_out:
        notes.append(f"terms not estimated, taken as zero: {', '.join(left_out)}")
    cross = _cross_text(sol)
    if cross:
        notes.append(cross)
    for t in sol.terms:
        if t not in sol.report.identifiable:
            notes.append(f"{t} not identifiable ({sol.report.status(t)}): reported as NaN")
    if not sol.k1_ok:
        notes.append("K1 not identifiable: no coefficient in g/g^n can be given (see combinations)")
    if sol.route == "fourier":
        notes.append(_FOURIER_TEXT)
    if sol.n_rep > 1:
        notes.append(_repeats_text(sol.n_rep))
    return tuple(notes)


def _assumptions(sol: _Solution, output_unit: str, *, given: bool) -> tuple[Assumption, ...]:
    axis = sol.axis
    geometry = ("a_i = cos theta, a_p = sin theta" if axis == "OA"
                else "a_i = sin theta, a_o = cos theta")
    sd = float(sol.sigma)
    per = "position" if sol.n_rep == 1 else f"position (mean of {sol.n_rep} readings)"
    noise_text = (f"noise SD given: {sd:.3g} {output_unit} per {per}" if given else
                  f"noise SD from the residuals: {sd:.3g} {output_unit} per {per} "
                  f"({sol.dof} degrees of freedom)")
    out = [
        Assumption("route", sol.route, "", _FOURIER_TEXT if sol.route == "fourier" else
                   "least-squares route: the design at the actual positions"),
        Assumption("rotation_axis", axis, "", f"rotation about {axis} ({geometry})"),
        Assumption("noise", "given" if given else "residuals", "", noise_text),
        Assumption("noise_sd", sd, output_unit),
        Assumption("repeats", sol.n_rep, "", _repeats_text(sol.n_rep)),
    ]
    left_out = _left_out(sol)
    if left_out:
        out.append(Assumption("terms_taken_zero", tuple(left_out), "",
                              f"terms not estimated, taken as zero: {', '.join(left_out)}"))
    cross = _cross_text(sol)
    if cross:
        out.append(Assumption("cross_nonlinearity", "Kpp" if axis == "OA" else "Koo", "", cross))
    few = _few_dof(sol, given)
    if few is not None:
        out.append(few)
    return tuple(out)
