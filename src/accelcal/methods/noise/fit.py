"""IEEE 952 noise coefficients fitted to the Allan variance, with honest uncertainties.

The overlapping Allan variance of a still recording is modelled as the sum
of the IEEE 952 terms (Annex C [IEEE952]_, [ElSheimy2008]_)::

    AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2

linear in ``C = (Q^2, N^2, B^2, K^2, R^2)``. :func:`fit_deviation` fits the
chosen terms by weighted least squares on the Allan *variance* with
``C >= 0`` (``scipy.optimize.nnls``). Weights: ``w_i = edf_i / (2 A_i^2)``,
the inverse chi-square variance of the point, with ``edf_i`` the point's
equivalent degrees of freedom (Greenhall-Riley, for the identified noise)
and ``A_i`` the *fitted model* at ``tau_i``, iterated to convergence
(started from the measured values). The model, not the measured value:
a point that scatters low would otherwise get a larger weight and pull the
fit down (weights from measured values bias every coefficient low by about
``2 / edf`` of the points that dominate it).

Uncertainties: the taus of one record share its samples, so their Allan
variances are correlated (0.3 to 0.9 between neighbouring octaves); the
WLS covariance ``(A'WA)^-1``, which treats them as independent, understates
the SD of N by 1.4x and of K by 1.9x (measured in
``tests/methods/noise/test_noise_fit.py``). The covariance of ``C`` is therefore the
sandwich ``J S J'``, ``J = (A'WA)^-1 A'W``, with ``S`` the covariance of the
Allan variances under the fitted model (:mod:`~accelcal.methods.noise.covariance`:
exact for the Q, N, K, R terms of Gaussian noise; the B floor's share on the
diagonal only). Coefficients by the delta method: ``X = sqrt(C)``,
``u(X) = u(C) / (2 X)``. A term whose ``C`` ends at the bound 0 is reported
as 0 with the standard uncertainty ``sqrt(u(C))`` of the unconstrained fit
(the size of the term the data cannot tell from zero), and a note says so.

The Reduction (family ``"noise"``, method ``"noise/ieee952-fit"``) has one sensor
(the channel) with the terms fitted, in the record's unit: N unit*sqrt(s),
B unit, K unit/sqrt(s), Q unit*s, R unit/s; ``dof = 0`` (the covariance is
computed, not scaled by residuals). Observations: ``tau`` (s), ``m``,
``n``, ``alpha``, ``edf``, ``dev``, ``dev_low``, ``dev_high`` (the deviation
with its interval), ``fitted`` (the fitted deviation at ``tau``) and, when
the fit started from samples, ``psd_frequency`` (Hz) and ``psd``
(unit^2/Hz, :mod:`~accelcal.methods.noise.psd`). Assumptions:
``weighting``, ``at_bound``, ``confidence``, ``goodness_of_fit`` (chi^2 and
dof of the misfit against the covariance ``S``), ``birge_ratio``,
``model_fits`` (p >= 0.05), ``uncertainty_scale`` (the Birge ratio when the
model does not fit: every uncertainty is multiplied by it) and
``alpha_source`` (per tau, :class:`~accelcal.signal.allan.deviations.Deviation`).

Goodness of fit (:func:`goodness_of_fit`): ``chi^2 = r' S^-1 r`` of the
residual Allan variances against the same ``S``, on taus less free terms;
when its p-value is below 0.05 the model does not describe the record, every
uncertainty is multiplied by the Birge ratio ``sqrt(chi^2 / dof)``
[Birge1932]_ and a note says so. The command line fits :data:`CLI_TERMS`
(N, K) by default; :func:`fit` keeps every term unless told.

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C (Allan variance of the noise terms,
   Eqs. (C.1)-(C.5), and their fit).
.. [IEEE1293] IEEE Std 1293-2018, annex (Allan variance of accelerometers).
.. [Riley2008] Riley W. J., Handbook of Frequency Stability Analysis, NIST
   SP 1065, 2008 (EDF, confidence intervals).
.. [ElSheimy2008] El-Sheimy N., Hou H., Niu X., Analysis and modeling of
   inertial sensors using Allan variance, IEEE Trans. Instrum. Meas. 57(1),
   2008, 140-149.
.. [Birge1932] Birge R. T., The calculation of errors by the method of least
   squares, Phys. Rev. 40, 1932, 207-227.
"""

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.results import Assumption, Estimate, Reduction

FAMILY = "noise"
"""The method family (key of :data:`accelcal.methods.REGISTRY`)."""

METHOD = "noise/ieee952-fit"
"""The reduction's name, as calibration records and the store carry it."""

TERMS = ("Q", "N", "B", "K", "R")
"""The IEEE 952 terms, by power of tau (-2 .. 2)."""

CLI_TERMS = ("N", "K")
"""Terms ``accelcal noise fit`` fits by default: unbiased on records without Q, B and R
(with every term fitted there, the terms at their bound bias K by about -11 %); the
goodness of fit says when a record needs more. :func:`fit` keeps :data:`TERMS`."""

POWERS = {"Q": -2, "N": -1, "B": 0, "K": 1, "R": 2}
FACTORS = {"Q": 3.0, "N": 1.0, "B": 2.0 * math.log(2.0) / math.pi, "K": 1.0 / 3.0, "R": 0.5}
"""AVAR of each term = FACTORS[t] * value^2 * tau^POWERS[t] (Eqs. (C.1)-(C.5) [IEEE952])."""

UNIT_SUFFIX = {"Q": "*s", "N": "*sqrt(s)", "B": "", "K": "/sqrt(s)", "R": "/s"}

MAX_ITERATIONS = 50
"""Re-weighting passes at most (convergence to 1e-10 relative takes 5-15)."""


def term_units(unit: str) -> dict[str, str]:
    """Unit of each coefficient for samples in ``unit`` (``N`` -> ``g*sqrt(s)``)."""
    return {t: f"{unit}{s}" for t, s in UNIT_SUFFIX.items()}


def term_avar(term: str, value: float, tau) -> np.ndarray:
    """Allan variance of one term at ``tau`` (Eqs. (C.1)-(C.5) [IEEE952])."""
    return FACTORS[term] * value**2 * np.asarray(tau, dtype=float) ** POWERS[term]


def model_avar(coefs: dict, tau) -> np.ndarray:
    """Allan variance of the sum of the terms in ``coefs`` at ``tau``."""
    tau = np.asarray(tau, dtype=float)
    return sum((term_avar(t, v, tau) for t, v in coefs.items() if t in POWERS),
               np.zeros_like(tau))


def check_terms(terms) -> tuple[str, ...]:
    """The terms to fit, in :data:`TERMS` order; an AccelcalError (``terms``) otherwise."""
    if isinstance(terms, str):
        terms = [t.strip() for t in terms.split(",")]
    terms = tuple(terms)
    bad = [t for t in terms if t not in TERMS]
    if bad or not terms or len(set(terms)) != len(terms):
        raise AccelcalError(f"terms {','.join(map(str, terms))!r}: give some of "
                            f"{','.join(TERMS)}, each once", parameter="terms")
    return tuple(t for t in TERMS if t in terms)


def fit(y, rate: float, *, terms=TERMS, taus="octave", confidence: float = 0.683,
        unit: str = "", psd: bool = True, provenance=None) -> Reduction:
    """Fit the IEEE 952 coefficients to the overlapping Allan deviation of samples ``y``.

    Parameters
    ----------
    y : array_like, shape (n,)
        Still-recording samples (finite), in ``unit``.
    rate : float
        Sample rate, Hz.
    terms : sequence of str or str
        Terms to fit (``"N,B,K"``), some of :data:`TERMS`.
    taus : str or sequence of int
        Tau set (:func:`accelcal.signal.allan.taus.tau_grid`).
    confidence : float
        Level of the deviation's intervals (observations ``dev_low/high``).
    unit : str
        Unit of the samples.
    psd : bool
        Also store the Welch PSD (observations ``psd_frequency``, ``psd``).
    provenance : dict, optional
        Stored in the reduction.

    Returns
    -------
    Reduction
        See the module docstring.
    """
    from accelcal.signal.allan.deviations import deviation

    y = np.asarray(y, dtype=float).reshape(-1)
    dev = deviation(y, rate, kind="oadev", taus=taus, confidence=confidence, unit=unit)
    spectrum = None
    if psd:
        from accelcal.methods.noise.psd import welch_psd

        spectrum = welch_psd(y, rate)
    return fit_deviation(dev, terms=terms, provenance=provenance, spectrum=spectrum,
                         mean=float(np.mean(y)))


def fit_deviation(dev, *, terms=TERMS, provenance=None, spectrum=None,
                  mean=None) -> Reduction:
    """Fit the IEEE 952 coefficients to an overlapping Allan deviation.

    Parameters
    ----------
    dev : accelcal.signal.allan.deviations.Deviation
        Of kind ``oadev`` (fields ``tau, m, n, dev, alpha, edf, lo, hi,
        confidence, unit, rate, samples``).
    terms : sequence of str or str
        Terms to fit.
    provenance : dict, optional
        Stored in the reduction.
    spectrum : (numpy.ndarray, numpy.ndarray), optional
        ``(frequency, psd)`` to keep in the observations.
    mean : float, optional
        The record's mean: reported as the coefficient ``bias`` (the run's
        bias, for :mod:`~accelcal.methods.noise.stability`), with the standard
        uncertainty ``ADEV(tau_max) sqrt(tau_max / T)`` (``T`` the record's
        length; exact for white noise, low for correlated noise, which is why
        the turn-on repeatability uses the scatter of several runs' means).

    Returns
    -------
    Reduction

    Raises
    ------
    AccelcalError
        For another kind of deviation, fewer taus than terms, or a
        deviation that is zero (a constant signal).
    """
    from scipy.optimize import nnls

    from accelcal.methods.noise.covariance import avar_covariance, bias_diagonal

    terms = check_terms(terms)
    if dev.kind != "oadev":
        raise AccelcalError(f"the IEEE 952 fit uses the overlapping Allan deviation, not "
                            f"{dev.kind}", parameter="kind")
    tau = np.asarray(dev.tau, dtype=float)
    avar = np.asarray(dev.dev, dtype=float) ** 2
    edf = np.asarray(dev.edf, dtype=float)
    if tau.size < len(terms):
        raise AccelcalError(f"{tau.size} taus cannot determine {len(terms)} terms; use more "
                            "taus (--taus all or decade) or fewer terms", parameter="terms")
    if not (np.all(avar > 0) and np.all(np.isfinite(avar))):
        raise AccelcalError("the Allan deviation is zero or not finite at some tau: the "
                            "signal is constant (or quantised to one level)", parameter="values")
    design = np.stack([FACTORS[t] * tau ** POWERS[t] for t in terms], axis=1)
    c, weight = _irls(design, avar, edf, nnls)
    values = dict(zip(terms, np.sqrt(c), strict=True))
    rest = {t: v for t, v in values.items() if t != "B"}
    sigma = avar_covariance(dev.m, dev.samples, dev.rate, rest)
    if "B" in values:
        b_avar = float(term_avar("B", values["B"], 1.0))
        sigma += np.diag(bias_diagonal(b_avar, model_avar(rest, tau), edf))
    cov_c, bound = _sandwich(design, weight, sigma, c)
    gof = goodness_of_fit(avar - design @ c, sigma, int((~bound).sum()))
    cov_c = cov_c * gof["scale"] ** 2
    est, notes = _estimate(terms, c, cov_c, bound, dev, avar, design, provenance, mean,
                           extra=_gof_notes(gof, terms))
    obs = {"tau": tau, "m": np.asarray(dev.m, dtype=float), "n": np.asarray(dev.n, dtype=float),
           "alpha": np.asarray(dev.alpha, dtype=float), "edf": edf,
           "dev": np.asarray(dev.dev, dtype=float), "dev_low": np.asarray(dev.lo, dtype=float),
           "dev_high": np.asarray(dev.hi, dtype=float), "fitted": np.sqrt(design @ c)}
    if spectrum is not None:
        obs["psd_frequency"], obs["psd"] = spectrum
    assumptions = (
        Assumption("weighting", "edf-model",
                   text=("weighted least squares on the Allan variance, weights edf / (2 A^2) "
                         "with A the fitted model (iterated); C >= 0 (NNLS)")),
        Assumption("at_bound", tuple(t for t, b in zip(terms, bound, strict=True) if b),
                   text="terms at the bound 0 (not resolved by the data)"),
        Assumption("confidence", float(dev.confidence), text="level of the deviation bars"),
        Assumption("goodness_of_fit", (gof["chi2"], gof["dof"]),
                   text=(f"chi^2 = {gof['chi2']:.3g} on {gof['dof']} dof against the covariance "
                         "of the Allan variances under the fitted model (p = "
                         f"{gof['p']:.2g})")),
        Assumption("birge_ratio", gof["birge"], text="sqrt(chi^2 / dof)"),
        Assumption("model_fits", gof["fits"],
                   text=("the noise model describes the record (p >= 0.05)" if gof["fits"] else
                         "the noise model does not describe the record (p < 0.05)")),
        Assumption("uncertainty_scale", gof["scale"],
                   text=("uncertainties multiplied by the Birge ratio because the model does "
                         "not fit" if gof["scale"] > 1.0 else "uncertainties not scaled")),
        Assumption("alpha_source", tuple(dev.alpha_source),
                   text="per tau: alpha identified, carried from the longest identified taus, "
                        "guessed or given"),
    )
    prov = {"samples": int(dev.samples), "rate_hz": float(dev.rate), "taus": int(tau.size),
            "unit": dev.unit, **(provenance or {})}
    return Reduction(family=FAMILY, method=METHOD, sensors=(est,), dof=0,
                     assumptions=assumptions, observations=obs, provenance=prov, notes=notes)


GOF_LEVEL = 0.05
"""p-value of chi^2 below which the model is taken not to describe the record."""


def goodness_of_fit(residual, sigma, free: int) -> dict:
    """Chi-square of the Allan variances' misfit against their covariance, and the Birge ratio.

    Parameters
    ----------
    residual : numpy.ndarray
        Measured less fitted Allan variance per tau.
    sigma : numpy.ndarray
        Covariance of the Allan variances under the fitted model.
    free : int
        Terms estimated off their bound.

    Returns
    -------
    dict
        ``chi2`` (``r' S^-1 r``), ``dof`` (taus less free terms), ``p`` (upper
        tail of chi-square), ``birge`` (``sqrt(chi2 / dof)``), ``fits`` (p >=
        :data:`GOF_LEVEL`) and ``scale``: the Birge ratio when the model does
        not fit (the uncertainties are multiplied by it: the scatter the
        model does not explain is spread over the terms [Birge1932]_), else 1.
    """
    from scipy.stats import chi2 as chi2_dist

    r = np.asarray(residual, dtype=float)
    dof = int(r.size - free)
    d = np.sqrt(np.diag(sigma))
    corr = sigma / np.outer(d, d)
    z = r / d
    stat = float(z @ np.linalg.lstsq(corr, z, rcond=1e-10)[0])
    if dof <= 0:
        return {"chi2": stat, "dof": dof, "p": 1.0, "birge": 1.0, "fits": True, "scale": 1.0}
    p = float(chi2_dist.sf(stat, dof))
    birge = math.sqrt(stat / dof)
    fits = p >= GOF_LEVEL
    return {"chi2": stat, "dof": dof, "p": p, "birge": birge, "fits": fits,
            "scale": 1.0 if fits else max(1.0, birge)}


def _gof_notes(gof, terms) -> tuple[str, ...]:
    notes = []
    if not gof["fits"]:
        notes.append(f"the noise model ({','.join(terms)}) does not describe the record: "
                     f"chi^2 = {gof['chi2']:.3g} on {gof['dof']} dof (p = {gof['p']:.2g}), "
                     f"Birge ratio {gof['birge']:.3g}; uncertainties multiplied by it. Look "
                     "at the figure: another term (B, R, Q) or a drift may be missing")
    return tuple(notes)


def _irls(design, avar, edf, nnls):
    """Non-negative WLS on the Allan variance, weights from the model, iterated."""
    model = avar.copy()
    c = np.zeros(design.shape[1])
    floor = 1e-12 * float(np.max(avar))
    for _ in range(MAX_ITERATIONS):
        weight = edf / (2.0 * np.maximum(model, floor) ** 2)  # var(A_i) = 2 A_i^2 / edf_i
        rw = np.sqrt(weight)
        a = design * rw[:, None]
        scale = np.linalg.norm(a, axis=0)
        new = nnls(a / scale, avar * rw, maxiter=50 * design.shape[1])[0] / scale
        fitted = design @ new
        done = np.allclose(new, c, rtol=1e-10, atol=0.0)
        c, model = new, np.where(fitted > 0, fitted, avar)
        if done:
            break
    return c, edf / (2.0 * np.maximum(model, floor) ** 2)


def _sandwich(design, weight, sigma, c):
    """Covariance of C: ``J S J'`` over the free terms; the unconstrained one for the rest."""
    p = design.shape[1]
    bound = c <= 0.0
    cov = np.zeros((p, p))

    def sandwich(cols):
        a = design[:, cols]
        aw = a.T * weight
        j = np.linalg.solve(aw @ a, aw)
        return j @ sigma @ j.T

    free = np.flatnonzero(~bound)
    if free.size:
        cov[np.ix_(free, free)] = sandwich(free)
    if bound.any():
        full = sandwich(np.arange(p))
        for k in np.flatnonzero(bound):
            cov[k, k] = full[k, k]
    return cov, bound


def _estimate(terms, c, cov_c, bound, dev, avar, design, provenance, mean, extra=()):  # noqa: PLR0917
    units = {**term_units(dev.unit or "unit"), "bias": dev.unit or "unit"}
    values = np.sqrt(c)
    with np.errstate(divide="ignore", invalid="ignore"):
        grad = np.where(bound, 0.0, 1.0 / (2.0 * values))  # dX/dC = 1 / (2 sqrt C)
    cov = cov_c * np.outer(grad, grad)
    for k in np.flatnonzero(bound):
        cov[k, k] = math.sqrt(max(cov_c[k, k], 0.0))  # std = sqrt(u(C)): see module docstring
    notes = []
    for k in np.flatnonzero(bound):
        notes.append(f"{terms[k]} at the bound 0: not resolved; its std is sqrt(u(C)) of the "
                     "unconstrained fit (the smallest term the data would show)")
    if "B" in terms:
        notes.append("B's standard uncertainty leaves out the correlation the flicker floor "
                     "induces between taus: it is optimistic (docs/noise.md)")
    if {"B", "K", "R"} <= set(terms):
        notes.append("with B and R fitted beside K, K's 95 % interval held the truth in 0.90 "
                     "of simulated records (the terms at their bound 0 distort it); fit "
                     "--terms N,K (or N,B,K) where B or R is absent (docs/coverage.md)")
    notes.extend(extra)
    fitted = np.sqrt(design @ c)
    names = terms
    if mean is not None:
        span = dev.samples / dev.rate
        mean_std = float(dev.dev[-1]) * math.sqrt(float(dev.tau[-1]) / span)
        names = (*terms, "bias")
        values = np.append(values, mean)
        cov = np.pad(cov, ((0, 1), (0, 1)))
        cov[-1, -1] = mean_std**2
    est = Estimate(names=names, values=values, covariance=cov, units={t: units[t] for t in names},
                   method=METHOD, residuals=np.asarray(dev.dev) - fitted,
                   dof=max(0, len(avar) - int((~bound).sum())), notes=tuple(notes),
                   provenance=dict(provenance or {}))
    return est, tuple(notes)


def coefficients(reduction) -> dict:
    """The fitted terms as JSON-ready data: ``unit``, ``<T>``, ``<T>_std``, ``navigation``.

    ``navigation`` maps each term to its values in the navigation units
    (:func:`navigation_units`; empty for samples in V, mV or counts).
    """
    est = reduction.estimate
    unit = reduction.provenance.get("unit", "")
    out = {"unit": unit}
    for name in est.names:
        out[name] = est[name]
        out[f"{name}_std"] = est.std_of(name)
    out["at_bound"] = list(reduction.assumed("at_bound", ()))
    gof = reduction.assumed("goodness_of_fit")
    if gof is not None:  # fits from before the goodness of fit have none
        out["chi2"], out["chi2_dof"] = float(gof[0]), int(gof[1])
        out["birge_ratio"] = float(reduction.assumed("birge_ratio"))
        out["model_fits"] = bool(reduction.assumed("model_fits"))
        out["uncertainty_scale"] = float(reduction.assumed("uncertainty_scale"))
    out["navigation"] = navigation_units({n: (est[n], est.std_of(n)) for n in est.names
                                          if n in NAVIGATION}, unit)
    return out


NAVIGATION = {
    "N": (("ug/sqrt(Hz)", "ug", 1.0), ("(m/s)/sqrt(h)", "si", 60.0)),
    "B": (("ug", "ug", 1.0),),
    "K": (("ug/sqrt(s)", "ug", 1.0), ("(m/s)/h^1.5", "si", 3600.0**1.5)),
    "Q": (("ug*s", "ug", 1.0),),
    "R": (("ug/h", "ug", 3600.0), ("(m/s)/h^2", "si", 3600.0**2)),
}
"""Term -> (unit, base, factor): value in ug-based units (``ug``) or m/s-based (``si``).

N in m/s^2 sqrt(s) = (m/s)/sqrt(s) is 60 (m/s)/sqrt(h); K in m/s^2/sqrt(s) is
3600^1.5 (m/s)/h^1.5; R in m/s^3 is 3600^2 (m/s)/h^2 [ElSheimy2008]."""


def navigation_units(values: dict, unit: str) -> dict:
    """Coefficients in the units of navigation error budgets.

    Parameters
    ----------
    values : dict
        Term -> ``(value, std)`` in the IEEE 952 units of ``unit``.
    unit : str
        Unit of the samples: ``g``, ``mg``, ``ug`` or ``m/s^2`` (others give ``{}``).

    Returns
    -------
    dict
        Term -> list of ``{"value", "std", "unit"}``.
    """
    from accelcal.units import STANDARD_GRAVITY

    to_si = {"g": STANDARD_GRAVITY, "mg": 1e-3 * STANDARD_GRAVITY,
             "ug": 1e-6 * STANDARD_GRAVITY, "m/s^2": 1.0}.get(unit)
    if to_si is None:
        return {}
    out = {}
    for term, (value, std) in values.items():
        rows = []
        for label, base, factor in NAVIGATION[term]:
            f = factor * to_si * (1e6 / STANDARD_GRAVITY if base == "ug" else 1.0)
            rows.append({"value": value * f, "std": std * f, "unit": label})
        out[term] = rows
    return out
