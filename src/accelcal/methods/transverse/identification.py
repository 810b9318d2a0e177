"""Identification of the cross-axis coefficients from shaker records (beyond GuanTang).

:func:`identify` fits k_o, k_p, k_oo, k_pp, k_op (and optionally other
terms) to the DC, w and 2w components of the records at several direction
angles, with the shaker's measured transverse motion in the regressors,
and returns a :class:`~accelcal.results.Reduction` (family ``transverse``,
method ``transverse/<route>``). :func:`identify_arrays` is the same
reduction vectorised over leading (trial) axes, returning arrays.

Assumptions the Reduction carries (:class:`~accelcal.results.Assumption`
names): ``amplitude`` (g), ``frequency`` (Hz), ``gravity`` (g),
``scale_factor`` (K1 used, output unit per g), ``route``, ``weighting``,
``reference_noise``. Observations: ``angle_deg`` (direction angles, deg),
``sT`` (the fundamental s_T per angle, output unit per g, with the IA
motion removed), ``s_I`` (the axial sensitivity for the relative values:
the records' ``eq20`` value, else K1). Non-zero terms of ``base`` that are
not fitted are the Reduction's ``fixed`` terms.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (13), (16), (24) as reconstructed in
   docs/domain.md section 3.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration sensitivity.
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3.1, three-parameter sine fit.
"""

import dataclasses

import numpy as np

from accelcal.aliasing import priors_of, unestimated
from accelcal.errors import AccelcalError
from accelcal.fitting import least_squares
from accelcal.identifiability import analyse
from accelcal.io.formats.shaker import MAX_MAGNITUDE, MIN_SCALE_FACTOR, ShakerRecords
from accelcal.methods.transverse.estimators import record_phasors, w_ratio
from accelcal.model import ErrorModel
from accelcal.results import Assumption, Reduction

FIT_TERMS = ("K0", "Ki", "K2", "K3", "K4", "Ko", "Kp", "Koo", "Kpp", "Kop", "Kio", "Kip",
             "K0_asym", "K1_asym")
"""Terms whose DC, w and 2w regressors :func:`identify` knows (``Ki`` is the
coefficient of a_i, 1 by definition of K1)."""

PRIOR_TERMS = tuple(t for t in FIT_TERMS if t != "Ki")
"""Terms a prior may bound (every fitted term but ``Ki``)."""

ROUTES = ("2w", "dc", "both", "w")
"""Components used by :func:`identify` besides the w phasor."""

def regressors(theta, p_v, p_n, p_ia, gravity: float) -> dict:
    """DC (vibrating and at rest), w and 2w regressors of each model term.

    For in-plane specific force ``(G + a_v) e_v + a_n e_n`` and IA motion
    ``a_ia`` with phasors ``P_v, P_n, P_ia`` (convention of
    :mod:`accelcal.signal.sinefit`), each term's contribution to the output
    divided by K1 is its coefficient times the regressor returned here.
    Products of ``x = x0 + Re(X e^{iwt})`` and ``y = y0 + Re(Y e^{iwt})``:
    DC ``x0 y0 + Re(X conj(Y)) / 2``, w ``x0 Y + y0 X``, 2w ``X Y / 2``.
    The asymmetry ``sgn(a_i) (K0' + K1' a_i) / 2`` of a sinusoidal IA motion
    ``Re(P e^{iwt})``: the square wave's w component ``(4 / pi) P / |P|``,
    and ``|a_i|``'s mean ``(2 / pi) |P|`` and 2w component
    ``(4 / (3 pi)) P^2 / |P|`` (the Fourier series of |cos| and sgn(cos)).

    Returns
    -------
    dict
        Term name (:data:`FIT_TERMS`) -> tuple ``(dc, dc_rest, w, w2)`` of
        arrays of shape ``(..., m)`` (w and w2 complex).

    References
    ----------
    .. [1] GuanTang eq. (13) with a_i = 0 plus the IA motion; docs/domain.md section 3.
    .. [2] Guan2021 eq. (3) (the asymmetry terms).
    """
    s, c = np.sin(theta), np.cos(theta)
    po = s * p_v + c * p_n  # OA component of the vibration phasor
    pp = c * p_v - s * p_n  # PA component
    o0, p0 = gravity * s, gravity * c
    pi = p_ia
    z = np.zeros_like(po)
    one = np.ones(po.shape)
    mag = np.abs(pi)
    unit = np.divide(pi, mag, out=np.zeros_like(pi), where=mag > 0)  # P / |P|, 0 without
    return {
        "K0": (one, one, z, z),
        "Ki": (0 * one, 0 * one, pi, z),
        "K2": (np.abs(pi) ** 2 / 2, 0 * one, z, pi**2 / 2),
        "K3": (0 * one, 0 * one, 3 * np.abs(pi) ** 2 * pi / 4, z),
        "K4": (3 * np.abs(pi) ** 4 / 8, 0 * one, z, np.abs(pi) ** 2 * pi**2 / 2),
        "Ko": (o0 * one, o0 * one, po, z),
        "Kp": (p0 * one, p0 * one, pp, z),
        "Koo": (o0**2 + np.abs(po) ** 2 / 2, o0**2 * one, 2 * o0 * po, po**2 / 2),
        "Kpp": (p0**2 + np.abs(pp) ** 2 / 2, p0**2 * one, 2 * p0 * pp, pp**2 / 2),
        "Kop": (o0 * p0 + (po * np.conj(pp)).real / 2, o0 * p0 * one, o0 * pp + p0 * po,
                po * pp / 2),
        "Kio": ((pi * np.conj(po)).real / 2, 0 * one, o0 * pi, pi * po / 2),
        "Kip": ((pi * np.conj(pp)).real / 2, 0 * one, p0 * pi, pi * pp / 2),
        "K0_asym": (0 * one, 0 * one, 2 / np.pi * unit, z),
        "K1_asym": (mag / np.pi, 0 * one, z, 2 / (3 * np.pi) * pi * unit),
    }


DEFAULT_FIT = ("Ko", "Kp", "Koo", "Kpp", "Kop")


_TERM_UNITS = {"K0": "g", "K2": "g/g^2", "K3": "g/g^3", "K4": "g/g^4", "Ko": "g/g", "Kp": "g/g",
               "Koo": "g/g^2", "Kpp": "g/g^2", "Kop": "g/g^2", "Kio": "g/g^2", "Kip": "g/g^2",
               "K0_asym": "g", "K1_asym": "g/g"}


def observation_columns(reg: dict, term: str, route: str) -> np.ndarray:
    """Real observation columns of ``term`` per angle: [DC shift], a1, b1, [a2, b2].

    Parameters
    ----------
    reg : dict
        :func:`regressors` output: per term ``(dc, dc_rest, w, w2)``.
    term : str
        A name of :data:`FIT_TERMS`.
    route : str
        Components used (:data:`ROUTES`): the DC shift with ``dc``/``both``,
        the 2w phasor with ``2w``/``both``; phasors ``P = a - i b``.
    """
    dc, dc_rest, w, w2 = reg[term]
    cols = [w.real, -w.imag]
    if route in ("2w", "both"):
        cols += [w2.real, -w2.imag]
    if route in ("dc", "both"):
        cols = [dc - dc_rest, *cols]
    return np.stack(np.broadcast_arrays(*cols), axis=-1)


def observation_covariance(records: ShakerRecords, ph: dict, route: str, k1: float, *,
                           reference: bool = True) -> np.ndarray:
    """Covariance of each angle's real observations ``[DC shift], a1, b1, [a2, b2]``.

    The output's sine-fit covariance (noise from its residuals), plus the
    output at rest's for the DC shift, plus (``reference=True``) the noise of
    the input-axis reference channel: the IA motion enters the w phasor with
    the known coefficient 1 (times K1, by the definition of K1), so its
    phasor's covariance adds ``K1^2 cov(P_ia)`` to the w components. The
    reference channels' noise entering through the fitted (small) cross-axis
    coefficients is of relative order ``|k_o|`` and neglected.

    Parameters
    ----------
    records : ShakerRecords
        The records, ``(..., m, n)``.
    ph : dict
        Their :func:`record_phasors`.
    route : str
        Components used (:data:`ROUTES`).
    k1 : float
        K1, output unit per g.
    reference : bool
        Include the IA reference channel's noise (when that channel is present).

    Returns
    -------
    numpy.ndarray
        Shape ``(..., m, q, q)``; a floor at rounding level keeps noise-free
        records usable (equal weights).

    References
    ----------
    .. [1] IEEE Std 1057-2017, sec. 4.1.3.1 (sine-fit covariance); GuanTang eq. (13)
       with the IA motion; docs/domain.md section 3.
    """
    u = ph["u"]
    use_dc = route in ("dc", "both")
    sel = ([0] if use_dc else []) + [1, 2] + ([3, 4] if route in ("2w", "both") else [])
    cu = u.cov_unit[np.ix_(sel, sel)]
    scale = np.abs(records.u).max(axis=(-1, -2), initial=1e-300)
    floor = 1e-15 * scale
    s_u = np.maximum(u.residual_std, floor[..., None])
    cov = s_u[..., None, None] ** 2 * cu
    if use_dc:
        s_r = np.maximum(ph["u_rest"].residual_std, floor[..., None])
        first = np.zeros(len(sel))
        first[0] = 1.0
        cov = cov + (s_r**2 * ph["u_rest"].cov_unit[0, 0])[..., None, None] * np.outer(first, first)
    if reference and "ref_ia" in ph:
        w = np.isin(sel, (1, 2)).astype(float)
        s_ia = k1 * ph["ref_ia"].residual_std
        cov = cov + s_ia[..., None, None] ** 2 * (cu * np.outer(w, w))
    return cov


def _system(records: ShakerRecords, route: str, terms, base: ErrorModel | None,
            scale_factor: float | None):
    """Whitened design, observations, K1, noisy?, phasors, held terms, terms left out.

    Shapes (..., N, p) and (..., N); the terms left out (neither fitted nor
    held) as whitened columns (..., N).
    """
    check_route(route)
    bad = [t for t in terms if t not in FIT_TERMS or t == "Ki"]
    if bad or not terms or len(set(terms)) != len(terms):
        raise AccelcalError(
            f"terms to fit {list(terms)} must be distinct names among "
            f"{', '.join(t for t in FIT_TERMS if t != 'Ki')}", parameter="terms"
        )
    m = records.theta.shape[-1]
    if m < 3:
        raise AccelcalError(
            f"{m} direction angle(s) at {records.amplitude:g} g: the fit needs at least 3 "
            "distinct angles (e.g. 0:330:30)"
        )
    k1 = scale_factor if scale_factor is not None else (
        base.K1 if base is not None else records.scale_factor)
    if k1 is None or not np.isfinite(k1) or k1 == 0:
        raise AccelcalError("the fit needs the sensor's scale factor K1 (output unit per g)",
                            parameter="scale_factor")
    if not MIN_SCALE_FACTOR <= abs(k1) <= MAX_MAGNITUDE:
        raise AccelcalError(
            f"{k1:g} is not the scale factor of an accelerometer (magnitude "
            f"{MIN_SCALE_FACTOR:g} to {MAX_MAGNITUDE:g} output unit per g)",
            parameter="scale_factor")
    if base is None:
        base = ErrorModel(K1=k1, output_unit=records.output_unit)
    ph = record_phasors(records)
    p_v = ph["ref"].phasors[..., 0]
    p_n = ph["ref_n"].phasors[..., 0] if "ref_n" in ph else np.zeros_like(p_v)
    p_ia = ph["ref_ia"].phasors[..., 0] if "ref_ia" in ph else np.zeros_like(p_v)
    reg = regressors(records.theta, p_v, p_n, p_ia, records.gravity)
    use_dc = route in ("dc", "both")
    if use_dc and records.u_rest is None:
        raise AccelcalError(
            "route 'dc' needs the output at rest at each angle (column u_rest) to form the DC "
            "shift; record it or use route 2w"
        )
    u = ph["u"]
    # real observations per angle, built from (dc, a1, b1, a2, b2) with P = a - i b
    idx = [1, 2] + ([3, 4] if route in ("2w", "both") else [])
    obs = [u.parameters[..., i] for i in idx]
    if use_dc:
        obs = [u.dc - ph["u_rest"].dc, *obs]

    y = np.stack(obs, axis=-1)  # (..., m, q)
    values = base.terms()
    held = {t: float(values[t]) for t in FIT_TERMS
            if t not in terms and t != "Ki" and values.get(t, 0.0) != 0.0}
    known = observation_columns(reg, "Ki", route)  # coefficient of a_i is 1 by the definition of K1
    for term, value in held.items():
        known = known + value * observation_columns(reg, term, route)
    y = y - k1 * known
    # (..., m, q, p)
    design = k1 * np.stack([observation_columns(reg, t, route) for t in terms], axis=-1)
    cov = observation_covariance(records, ph, route, k1)
    chol = np.linalg.cholesky(cov)
    yw = np.linalg.solve(chol, y[..., None])[..., 0]
    dw = np.linalg.solve(chol[..., None, :, :], design.swapaxes(-1, -2)[..., None]).squeeze(-1)
    dw = dw.swapaxes(-1, -2)  # (..., m, q, p)
    lead = y.shape[:-2]
    scale = np.abs(records.u).max(axis=(-1, -2), initial=1e-300)
    out = {t: np.linalg.solve(chol, k1 * observation_columns(reg, t, route)[..., None])
           [..., 0].reshape(*lead, -1)
           for t in FIT_TERMS if t != "Ki" and t not in terms and t not in held}
    return (dw.reshape(*lead, -1, len(terms)), yw.reshape(*lead, -1), k1,
            bool(np.all(u.residual_std > 1e-12 * scale[..., None])), ph, held, out)


def identify(records: ShakerRecords, *, route: str = "2w", terms=DEFAULT_FIT,
             base: ErrorModel | None = None, scale_factor: float | None = None,
             priors="default") -> Reduction:
    """Identify cross-axis coefficients from shaker records at several angles.

    Fits the chosen terms (default k_o, k_p, k_oo, k_pp, k_op) to the w
    phasor of the output (k_o, k_p through ``B(theta)``, and the ``2 G C``
    part under gravity) and to the 2w phasor and/or the DC shift from rest
    (k_oo, k_pp, k_op through ``C(theta)``). The regressors use the
    reference channels, so a measured transverse motion of the shaker
    (``ref_n``, ``ref_ia``) is separated exactly. Observations are weighted
    by the covariance of each angle's observations
    (:func:`observation_covariance`: the output's sine fit and the IA
    reference channel's noise, both estimated from the fit residuals), so
    the returned covariance is ``(A' W A)^-1``.

    Parameters
    ----------
    records : ShakerRecords
        Records of shape ``(m, n)``, m >= 3 angles.
    route : {"2w", "dc", "both", "w"}
        Components used besides the w phasor; ``dc`` needs ``u_rest``.
    terms : sequence of str
        Terms to fit (names of :data:`FIT_TERMS` except ``Ki``).
    base : ErrorModel, optional
        Values of the terms not fitted (default: all zero) and K1.
    scale_factor : float, optional
        K1, output unit per g (default: ``base.K1`` or the records' value).
    priors : "default", "none", None or dict
        What is known of the terms neither fitted nor held in ``base``, which
        enter through the shaker's own IA motion and the fit takes as zero:
        ``"default"`` bounds each by twice the embedded default
        accelerometer's magnitude (rectangular); a dict maps a term to an
        :class:`~accelcal.aliasing.Prior`; ``"none"`` or None propagates
        nothing and ``aliases`` state the rows each term would move per unit
        (:func:`accelcal.aliasing.unestimated`). Without IA motion they do
        not enter and nothing is added.

    Returns
    -------
    Reduction
        Family ``transverse``, method ``transverse/<route>``; one sensor whose
        values are in g/g^n, with the weighted residuals (1 = one standard
        deviation) and their degrees of freedom; assumptions, fixed terms and
        observations as listed in the module docstring; ``quantities`` show
        Ko and Kp as transverse sensitivities (mg/g); the priors' Type B
        contributions in ``type_b`` and in the covariance.

    Raises
    ------
    AccelcalError
        For fewer than 3 angles, an unknown term or route, a rank-deficient
        design (e.g. k_oo, k_pp, k_op from the w phasor alone without gravity),
        or a zero reference amplitude.

    Notes
    -----
    Neglected: the noise of the reference channels along the vibration and
    across it, which enters through the small fitted coefficients (relative
    order ``|k_o|``), and the 3w component. The asymmetry terms' response
    to IA motion is the Fourier series of a continuous square wave; sampled
    at n points per period its harmonics k = n +- 1 alias onto w, a
    departure of order 1/n of K0''s part.

    References
    ----------
    .. [1] GuanTang eqs. (13), (16), (24), beyond the paper; docs/domain.md section 3.
    """
    if records.u.ndim != 2:
        raise AccelcalError("identify takes records of shape (angles, samples); "
                            "use identify_arrays for stacked trials")
    terms = tuple(terms)
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite results are refused below
        design, y, k1, noisy, ph, held, left = _system(records, route, terms, base,
                                                       scale_factor)
    method = f"transverse/{route}"
    units = {t: _TERM_UNITS[t] for t in terms}
    provenance = {"angles": int(records.theta.size), "amplitude_g": records.amplitude,
                  "gravity_g": records.gravity, "scale_factor": k1}
    finite = np.isfinite(design).all() and np.isfinite(y).all()
    est = least_squares(design, y, names=terms, units=units, method=method, sigma=1.0,
                        provenance=provenance) if finite else None
    if est is None or not (np.isfinite(est.values).all() and np.isfinite(est.covariance).all()):
        raise AccelcalError(
            "the coefficients or their uncertainties are not finite (beyond the float range): "
            "the records' values are not those of a shaker test"
        )
    ident = analyse(design, terms, units=units)
    un = unestimated(design, terms, left, sigma=None,
                     identified=[t in ident.identifiable for t in terms],
                     priors=priors_of(priors, tuple(left), PRIOR_TERMS,
                                      "a term of the shaker model"))
    est = dataclasses.replace(est, covariance=est.covariance + un.covariance, labels=un.labels)
    source = ("given" if scale_factor is not None else
              "from the model" if base is not None else "from the records")
    unit = records.output_unit
    assumptions = (
        Assumption("amplitude", float(records.amplitude), "g",
                   f"shaker vibration amplitude {records.amplitude:g} g"),
        Assumption("frequency", float(records.frequency), "Hz",
                   f"vibration frequency {records.frequency:g} Hz"),
        Assumption("gravity", float(records.gravity), "g",
                   f"static gravity along the vibration axis {records.gravity:g} g"),
        Assumption("scale_factor", float(k1), f"{unit}/g",
                   f"scale factor K1 = {k1:.9g} {unit}/g ({source})"),
        Assumption("route", route, "", f"coefficients fitted to {ROUTE_TEXT[route]}"),
        Assumption("weighting", "sine-fit covariance", "",
                   "observations weighted by each record's sine-fit covariance"),
        Assumption("reference_noise", "input axis", "",
                   "the IA reference channel's noise included in the weights; the other "
                   "reference channels' noise, entering through the small fitted "
                   "coefficients, neglected"),
    )
    notes = (() if noisy else ("noise-free records: covariance is not meaningful",)) + ((
        "terms of the IA motion taken as zero bounded by priors (" + ", ".join(
            f"{p.name} +-{p.value:.3g} {p.unit} ({p.source})" for p in un.priors)
        + "), propagated as Type B to the rows they move",) if un.priors else ())
    return Reduction(
        family="transverse", method=method, sensors=(est,),
        identifiability=ident, type_b=un.contributions, aliases=un.aliases,
        priors=un.priors,
        assumptions=assumptions, fixed=held,
        observations={"angle_deg": np.rad2deg(records.theta),
                      "sT": np.abs(w_ratio(ph, k1)),
                      "s_I": _axial_or(records, k1)},
        quantities={"Ko": "transverse", "Kp": "transverse"},
        provenance={**provenance, "route": route, "terms": list(terms)}, notes=notes,
    )



ROUTE_TEXT = {
    "2w": "the w and 2w phasors of the output",
    "dc": "the w phasor and the DC shift from rest of the output",
    "both": "the w and 2w phasors and the DC shift from rest of the output",
    "w": "the w phasor of the output",
}
"""What each route fits the coefficients to (for people: assumptions and reports)."""


def _axial_or(records: ShakerRecords, k1: float) -> float:
    """The records' axial sensitivity (eq20) when their metadata give a usable one, else K1."""
    table = records.metadata.get("axial_sensitivity")
    value = table.get("eq20") if isinstance(table, dict) else None
    ok = isinstance(value, int | float) and not isinstance(value, bool) and np.isfinite(value)
    return float(value) if ok and value != 0 else float(k1)


def check_route(route: str) -> None:
    """Refuse a ``route`` not in :data:`ROUTES` (AccelcalError)."""
    if route not in ROUTES:
        raise AccelcalError(f"{route!r} is not one of {', '.join(ROUTES)}", parameter="route")


def identify_arrays(records: ShakerRecords, *, route: str = "2w", terms=DEFAULT_FIT,
                    base: ErrorModel | None = None, scale_factor: float | None = None):
    """Vectorised :func:`identify` over leading (trial) axes of the records.

    Returns
    -------
    values : numpy.ndarray, shape (..., p)
    covariance : numpy.ndarray, shape (..., p, p)

    References
    ----------
    .. [1] docs/domain.md section 3 (identification beyond GuanTang).
    """
    design, y, *_ = _system(records, route, tuple(terms), base, scale_factor)
    ata = design.swapaxes(-1, -2) @ design
    cov = np.linalg.inv(ata)
    values = (cov @ (design.swapaxes(-1, -2) @ y[..., None]))[..., 0]
    return values, cov
