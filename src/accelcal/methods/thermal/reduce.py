"""Reduction of a thermal test: temperature polynomials, hysteresis, warm-up, residuals.

:func:`reduce_thermal` reduces a
:class:`~accelcal.io.formats.thermal.ThermalRecord` to one
:class:`~accelcal.results.Reduction` (family ``"thermal"``, method
``"thermal/wls"``). Coefficient names (docs/thermal.md):

``K0, K0_T1 .. K0_Tm, K0_hyst`` (and likewise K2, Kp or Ko)
    The term at the reference temperature T0, its k-th temperature
    coefficient (per degC^k) and the heating-minus-cooling hysteresis.
``K1, K1_T1 .. K1_Tm, K1_hyst``
    The scale factor at T0 (output unit per g); its temperature
    coefficients and hysteresis are relative (1e-6 = 1 ppm).
``warmup_tau, warmup_amplitude, warmup_K0``
    Warm-up time constant (s), bias change from turn-on to settled (g) and
    the settled bias (g), when the record has a warm-up.

A row estimates what the plateau tumbles estimate: ``K0+Kpp`` and ``K2-Kpp``
about OA (``K0+Koo``, ``K2-Koo`` about PA) at T0, named so; their
temperature coefficients ``K0_T1``... are those of the combination. The
terms every tumble takes as zero and could separate (K0', K1') move the
rows at T0 by the tumble's alias matrix, the same at every plateau: their
priors (:mod:`accelcal.aliasing`, default twice the default accelerometer's
magnitude) are propagated once, as itemised Type B contributions to those
rows (K1 carries K0': 1.6 V/g per g about OA, 2.8 ppm for the default
accelerometer); the temperature coefficients are not moved by a constant
term.

The plateau temperatures are uncertain (``temperature_sd``, default the
standard error of the mean of each plateau's readings): each plateau's
variance becomes ``s_j^2 + (dy/dT)^2 u(T_j)^2`` with the slope of a first
fit (effective variance [Orear]), and the polynomial is fitted again.

The K1 polynomial ``b(T) = sum b_k dT^k`` is fitted in output unit per g
and converted: ``K1 = b_0``, ``K1_Tk = b_k / b_0`` with first-order
covariance propagation. Polynomials of different terms are fitted
separately (their cross-covariance, from the tumbles' correlation of K0 and
K1, is left out: zero in the covariance).

Assumption names: ``order_selection``, ``orders``, ``reference_temperature``,
``valid_range``, ``settling``, ``scatter``, ``hysteresis``, ``warmup``.
Observations: ``temperature``, ``setpoint``, ``direction``,
``settling_time``, ``settling_rate`` (per plateau) and per fitted term
``<K>``, ``<K>_std``, ``<K>_fit``, ``<K>_residual`` (the residual after
compensation, without the hysteresis); ``warmup_t``, ``warmup_output``,
``warmup_fitted``.

References
----------
.. [DOMAIN] accelcal domain notes, section 8.
.. [IEEE1293] IEEE Std 1293-2018, thermal sensitivity of bias and scale factor.
.. [Draper] Draper N. R., Smith H., Applied Regression Analysis, 3rd ed., 1998.
.. [Orear] Orear J., Least squares when both variables have uncertainties,
   Am. J. Phys. 50, 912 (1982) (effective variance).
.. [GUM] JCGM 100:2008, secs. 4.3, 5.1.2, G.4.1.
"""

import numpy as np

from accelcal.aliasing import propagate
from accelcal.errors import AccelcalError
from accelcal.methods.thermal.plateaus import Plateau, reduce_plateaus
from accelcal.methods.thermal.poly import ALPHA, fit_polynomial
from accelcal.methods.thermal.settle import RATE_LIMIT, TOLERANCE, WINDOW_S, check_settings
from accelcal.methods.thermal.warmup import fit_warmup
from accelcal.model import ErrorModel, term_unit
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.terms import TEMPERATURE_TERMS, TemperatureTerms, check_temperature

FAMILY = "thermal"
METHOD = "thermal/wls"
ORDERS = ("auto", 1, 2, 3)
_HYST_QUANTITY = {"K0": "bias", "K1": "ratio", "K2": "second", "Ko": "misalignment",
                  "Kp": "misalignment"}


MAX_TEMPERATURE_SD = 100.0
"""Largest plateau-temperature standard uncertainty taken, degC (beyond any chamber's span)."""


def default_terms(rotation_axis: str) -> tuple[str, ...]:
    """Terms fitted against temperature by default: bias, scale factor, K2, misalignment."""
    return ("K0", "K1", "K2", "Kp" if rotation_axis == "OA" else "Ko")


def reduce_thermal(record, *, order="auto", reference: float = 25.0, terms=None,
                   alpha: float = ALPHA, window: float = WINDOW_S,
                   rate_limit: float = RATE_LIMIT, tolerance: float = TOLERANCE,
                   temperature_sd: float | None = None, priors="default") -> Reduction:
    """Reduce a thermal test to temperature polynomials with covariance (module docs).

    Parameters
    ----------
    record : ThermalRecord
    order : {"auto", 1, 2, 3}
        Highest power of (T - T0), or chosen per term by the F-test
        (:mod:`~accelcal.methods.thermal.poly`).
    reference : float
        T0, degC.
    terms : sequence of str, optional
        Terms fitted against temperature (K0 and K1 always): default
        :func:`default_terms`.
    alpha : float
        Level of the order-selection F-test.
    window, rate_limit, tolerance : float
        Settling criterion (s, degC/min, degC).
    temperature_sd : float, optional
        Standard uncertainty of each plateau's temperature, degC (a
        thermometer's, independent between plateaus). Default: the standard
        error of the mean of the plateau's readings.
    priors : "default", "none", None or dict
        Priors of the terms the plateau tumbles take as zero, as for
        :func:`accelcal.methods.tumble.reduce_tumble`.

    Returns
    -------
    accelcal.results.Reduction

    Raises
    ------
    AccelcalError
        One plateau, plateaus that never settle, too few plateaus for the
        order, a bad order, term or reference temperature.

    References
    ----------
    .. [1] DOMAIN section 8; IEEE 1293 thermal tests; Draper and Smith 6.1.
    """
    if order not in ORDERS:
        raise AccelcalError(f"order {order!r} is not one of auto, 1, 2, 3", parameter="order")
    if not (0 < alpha < 1):
        raise AccelcalError(f"alpha = {alpha} must be between 0 and 1", parameter="alpha")
    check_settings(window, rate_limit, tolerance)
    if temperature_sd is not None and not (np.isfinite(temperature_sd)
                                           and 0 <= temperature_sd <= MAX_TEMPERATURE_SD):
        raise AccelcalError(f"must be a standard uncertainty from 0 to {MAX_TEMPERATURE_SD:g} "
                            f"degC, got {temperature_sd:g}", parameter="temperature_sd")
    t0 = float(check_temperature(reference, "the reference temperature"))
    bases = _bases(terms, record.rotation_axis)
    plateaus = reduce_plateaus(record, window=window, rate_limit=rate_limit,
                               tolerance=tolerance)
    temp = np.array([p.temperature for p in plateaus])
    u_temp = (np.array([p.temperature_sd for p in plateaus]) if temperature_sd is None
              else np.full(temp.size, float(temperature_sd)))
    dirs = np.array([p.direction for p in plateaus])
    fits = {b: _fit(b, plateaus, temp - t0, dirs, order=order, alpha=alpha, u_temp=u_temp)
            for b in bases}
    names, values, blocks, units = [], [], [], {}
    for b, (fit, vals, cov) in fits.items():
        labels = [b, *(f"{b}_T{k}" for k in range(1, fit.order + 1))]
        labels += [f"{b}_hyst"] if fit.hysteresis else []
        names += labels
        values += list(vals)
        blocks.append(cov)
        units |= {n: _unit(n, b, record.output_unit) for n in labels}
    obs = _observations(plateaus, fits, temp, dirs)
    notes, warm = [], None
    if record.rows("warm-up").size:
        try:
            warm = _warmup(record, plateaus, fits, t0)
        except AccelcalError as exc:
            notes.append(f"warm-up not reduced: {exc.message}")
    if warm is not None:
        names += ["warmup_tau", "warmup_amplitude", "warmup_K0"]
        values += list(warm[0])
        blocks.append(warm[1])
        units |= {"warmup_tau": "s", "warmup_amplitude": "g", "warmup_K0": "g"}
        obs |= warm[2]
    cov = _block_diagonal(blocks)
    dof = min(f.dof for f, _, _ in fits.values())
    notes += _residual_notes(fits, plateaus)
    plateau_est = plateaus[0].reduction.estimate
    labels = {b: plateau_est.label(b) for b in bases if plateau_est.label(b) != b}
    cov_b, type_b, used, aliases = _type_b(plateaus[0].reduction, names, labels, units, priors,
                                           record.output_unit)
    notes += _birge_notes(fits, labels) + _type_b_notes(used, u_temp, temperature_sd)
    est = Estimate(names=tuple(names), values=np.array(values), covariance=cov + cov_b,
                   units=units, method=METHOD, dof=dof, notes=tuple(notes),
                   provenance={"plateaus": len(plateaus)}, labels=labels)
    lo, hi = float(temp.min()) - tolerance, float(temp.max()) + tolerance  # plateaus +- band
    return Reduction(
        family=FAMILY, method=METHOD, sensors=(est,), dof=dof,
        assumptions=_assumptions(fits, order=order, alpha=alpha, t0=t0, span=(lo, hi),
                                 window=window, rate_limit=rate_limit, warm=warm),
        observations=obs, models=(_model(plateaus, fits, t0, (lo, hi), record.output_unit),),
        quantities={**{f"{b}_hyst": _HYST_QUANTITY[b] for b in bases},
                    "warmup_amplitude": "bias", "warmup_K0": "bias"},
        provenance={"rotation_axis": record.rotation_axis, "output_unit": record.output_unit,
                    "plateaus": len(plateaus), "setpoints": list(record.setpoints),
                    "reference_degC": t0, "orders": {b: f.order for b, (f, _, _) in
                                                     fits.items()},
                    "dof": {b: f.dof for b, (f, _, _) in fits.items()},
                    "plateau_method": plateaus[0].reduction.method,
                    "simulated": bool(record.metadata.get("simulated", False)),
                    "birge_ratio": {b: f.birge for b, (f, _, _) in fits.items()},
                    "temperature_sd": [float(u) for u in u_temp]},
        notes=tuple(notes), type_b=type_b, aliases=aliases, priors=used,
    )


def _type_b(tumble, names, labels, units, priors, output_unit):  # noqa: PLR0917
    """Type B of the priors of the terms each plateau's tumble takes as zero, at T0.

    The tumble's alias entries (row at a plateau per unit of the term) are the
    same at every plateau; they move the rows at T0 (``K0``, ``K1``, ...) and
    not the temperature coefficients.
    """
    from accelcal.methods.tumble.unestimated import check_priors

    terms = tuple(dict.fromkeys(a.term for a in tumble.aliases))
    if not terms:
        return 0.0, (), (), ()
    given = check_priors(priors, terms, output_unit)
    rows = tuple(labels.get(n, n) for n in names)
    matrix = np.zeros((len(names), len(terms)))
    for a in tumble.aliases:
        if a.row in rows:
            matrix[rows.index(a.row), terms.index(a.term)] = a.sensitivity
    cov, parts = propagate(matrix, rows, terms, given,
                           row_units={labels.get(n, n): u for n, u in units.items()})
    entries = tuple(a for a in tumble.aliases if a.row in rows)
    return cov, parts, tuple(given[t] for t in terms if t in given), entries


CONSERVATIVE = (0.83, 0.90, 0.97, 0.99)
"""SD ratio (low, high) and coverage of the 95 % intervals (low, high) of the polynomials'
rows measured by the coverage harness at order 2 (15 plateaus; docs/thermal.md), where the
plateaus' own covariance is kept."""


def _birge_notes(fits, labels) -> list[str]:
    """What each polynomial's covariance rests on, and which rows' intervals are conservative.

    Where the plateaus' own covariance is kept (``R_B <= 1``), its rows are
    named: the Birge ratio only scales up, and the plateaus' noise carries
    the drift during each tumble (:data:`CONSERVATIVE`).
    """
    scaled = [f"{b} (R_B = {f.birge:.3g})" for b, (f, _, _) in fits.items() if f.scaled]
    kept = [b for b, (f, _, _) in fits.items() if not f.scaled]
    out = []
    if scaled:
        out.append("scatter between plateaus beyond their covariance: covariance scaled up by the "
                   "Birge ratio squared for " + ", ".join(scaled) + " (residual dof)")
    if kept:
        out.append("scatter between plateaus within their covariance (Birge ratio <= 1): the "
                   "plateaus' own covariance kept for " + ", ".join(kept))
        rows = [r for b in kept for r in (labels.get(b, b),
                                           *(f"{b}_T{k}" for k in range(1, fits[b][0].order + 1)),
                                           *([f"{b}_hyst"] if fits[b][0].hysteresis else []))]
        sd_lo, sd_hi, lo, hi = CONSERVATIVE
        out.append(
            f"{', '.join(rows)}: 95 % intervals conservative: each plateau's noise, from its "
            "tumble's residuals, carries the sensor's drift during that tumble, so the plateaus' "
            "covariance exceeds their scatter, and the Birge ratio scales it up only (in "
            f"simulation at order 2 the intervals covered {100 * lo:.0f}-{100 * hi:.0f} %, "
            f"SD ratio {sd_lo:.2f}-{sd_hi:.2f}); the stated uncertainty is kept")
    return out


def _type_b_notes(used, u_temp, given) -> list[str]:
    how = "given" if given is not None else "standard error of the mean of the readings"
    out = [(f"plateau temperatures uncertain by {np.min(u_temp):.3g} to "
            f"{np.max(u_temp):.3g} degC ({how}), propagated as effective variance")]
    if used:
        out.append("terms each plateau's tumble takes as zero bounded by priors (" + ", ".join(
            f"{p.name} {'+-' if p.distribution == 'rectangular' else 'u = '}{p.value:.3g} "
            f"{p.unit} ({p.source})" for p in used) + "), propagated as Type B to the rows at "
            "T0 they move (Welch-Satterthwaite degrees of freedom: Reduction.dof_eff)")
    return out


def _bases(terms, axis: str) -> tuple[str, ...]:
    allowed = ("K0", "K1", "K2", "Kp" if axis == "OA" else "Ko")
    if terms is None:
        return default_terms(axis)
    terms = tuple(terms)
    bad = [t for t in terms if t not in allowed]
    if bad:
        raise AccelcalError(f"term {bad[0]!r} cannot be fitted against temperature from a tumble "
                            f"about {axis}; choose from {', '.join(allowed)}", parameter="terms")
    return tuple(t for t in allowed if t in {"K0", "K1", *terms})


def _unit(name: str, base: str, output_unit: str) -> str:
    if name in TEMPERATURE_TERMS:
        return TEMPERATURE_TERMS[name].unit
    if name.endswith("_hyst"):
        return "1" if base == "K1" else term_unit(base, output_unit)
    return term_unit(name, output_unit)


def _fit(base: str, plateaus: list[Plateau], dt, dirs, *, order, alpha, u_temp):
    """The fit and its values/covariance in the reported parametrisation (K1 relative).

    With uncertain temperatures the plateaus' variances take the effective
    variance ``(dy/dT)^2 u(T)^2`` of a first fit [Orear] and the polynomial
    is fitted again at the order chosen.
    """
    y = np.array([p.value(base) for p in plateaus])
    s = np.array([p.std(base) for p in plateaus])
    nu_w = int(sum(p.reduction.dof for p in plateaus))  # the pooled noise's dof
    fit = fit_polynomial(y, s, dt, dirs, order=order, alpha=alpha, what=base, weights_dof=nu_w)
    if np.any(u_temp > 0):
        slope = np.polynomial.polynomial.polyval(
            dt, np.polynomial.polynomial.polyder(fit.values[: fit.order + 1]))
        s = np.sqrt(s**2 + (slope * u_temp) ** 2)  # effective variance [Orear]
        fit = fit_polynomial(y, s, dt, dirs, order=fit.order, alpha=alpha, what=base,
                             weights_dof=nu_w)
    if base != "K1":
        return fit, fit.values, fit.covariance
    b = fit.values
    vals = np.r_[b[0], b[1:] / b[0]]  # K1, K1_Tk = b_k / b_0 (and K1_hyst = b_H / b_0)
    jac = np.diag(np.r_[1.0, np.full(b.size - 1, 1.0 / b[0])])
    jac[1:, 0] = -b[1:] / b[0] ** 2
    return fit, vals, jac @ fit.covariance @ jac.T


def _block_diagonal(blocks) -> np.ndarray:
    n = sum(b.shape[0] for b in blocks)
    out = np.zeros((n, n))
    i = 0
    for b in blocks:
        out[i:i + b.shape[0], i:i + b.shape[0]] = b
        i += b.shape[0]
    return out


def _observations(plateaus, fits, temp, dirs) -> dict:
    obs = {"temperature": temp, "direction": dirs.astype(float),
           "setpoint": np.array([p.setpoint for p in plateaus]),
           "settling_time": np.array([p.settling.settling_time for p in plateaus]),
           "settling_rate": np.array([p.settling.rate for p in plateaus])}
    for b, (fit, _, _) in fits.items():
        y = np.array([p.value(b) for p in plateaus])
        poly = fit.fitted - (0.5 * dirs * fit.values[-1] if fit.hysteresis else 0.0)
        obs |= {b: y, f"{b}_std": np.array([p.std(b) for p in plateaus]),
                f"{b}_fit": fit.fitted, f"{b}_residual": y - poly}
    return obs


def _residual_notes(fits, plateaus) -> list[str]:
    """Residual after compensation across the range, in engineering units."""
    out = []
    for b, (fit, _, _) in fits.items():
        y = np.array([p.value(b) for p in plateaus])
        dirs = np.array([p.direction for p in plateaus])
        r = y - (fit.fitted - (0.5 * dirs * fit.values[-1] if fit.hysteresis else 0.0))
        scale, unit = (1e6 / fit.values[0], "ppm") if b == "K1" else (
            (1e6, "urad") if b in ("Ko", "Kp") else (1e6, "ug" if b == "K0" else "ug/g^2"))
        out.append(f"residual of {b} after compensation (order {fit.order}) across the range: "
                   f"RMS {np.sqrt(np.mean(r**2)) * abs(scale):.3g} {unit}, max "
                   f"{np.abs(r).max() * abs(scale):.3g} {unit}")
    return out


def _warmup(record, plateaus, fits, t0):
    """Warm-up values (tau, amplitude g, settled K0 g), covariance and observations."""
    from accelcal.physics.tumble import specific_force

    rows = record.rows("warm-up")
    t, y = record.t[rows], record.output[rows]
    w = fit_warmup(t, y)
    t_w = float(np.mean(record.temperature[rows]))
    k1_fit = fits["K1"][0]
    k1 = float(k1_fit.curve(t_w - t0)[0][0])
    nearest = min(plateaus, key=lambda p: abs(p.temperature - t_w))
    model = nearest.reduction.models[0]
    est = nearest.reduction.estimate
    a = specific_force(np.array([record.angle_rad[rows[0]]]), record.rotation_axis)
    rest = float(model.output_g(*a)[0]) - model.K0  # a_i + K2 a_i^2 + ... at the position
    grad = np.array([float(model.replace(**{n: est[n] + 1.0}).output_g(*a)[0]) - model.K0
                     - rest if n not in ("K0", "K1") else 0.0 for n in est.names])
    c, amp, tau = w.values
    values = np.array([tau, amp / k1, c / k1 - rest])
    jac = np.array([[0, 0, 1], [0, 1 / k1, 0], [1 / k1, 0, 0]])
    cov = jac @ w.covariance @ jac.T
    cov[2, 2] += grad @ np.nan_to_num(est.covariance) @ grad  # the position's other terms
    return values, cov, {"warmup_t": t, "warmup_output": y, "warmup_fitted": w.fitted}


def _model(plateaus, fits, t0, span, output_unit) -> ErrorModel:
    """The compensation's error model: polynomials at T0, other terms averaged over plateaus."""
    base_terms, tc = {}, {}
    for b, (fit, vals, _) in fits.items():
        base_terms[b] = float(vals[0])
        tc |= {f"{b}_T{k}": float(vals[k]) for k in range(1, fit.order + 1)}
    est0 = plateaus[0].reduction.estimate
    for name in est0.names:
        if name in base_terms:
            continue
        v = np.array([p.value(name) for p in plateaus])
        s = np.array([p.std(name) for p in plateaus])
        if np.isfinite(v).all() and np.all(s > 0):
            base_terms[name] = float(np.sum(v / s**2) / np.sum(1 / s**2))
    model = ErrorModel.from_terms(base_terms, output_unit=output_unit)
    return model.replace(temperature=TemperatureTerms(t0, tc, span))


def _assumptions(fits, *, order, alpha, t0, span, window, rate_limit, warm) -> tuple:
    orders = tuple(f.order for f, _, _ in fits.values())
    how = (f"order chosen per term by the F-test of the added power at level {alpha:g}; the "
           "intervals are conditional on that choice and cover less than 95 % when a small "
           "higher-order term is missed (about 90 % in docs/thermal.md's simulation): fix "
           "the order for a calibration certificate" if order == "auto"
           else f"fixed order {order}")
    hyst = [b for b, (f, _, _) in fits.items() if f.hysteresis]
    out = [
        Assumption("order_selection", "F-test" if order == "auto" else "fixed", "", how),
        Assumption("orders", orders, "", "polynomial orders: " + ", ".join(
            f"{b} {f.order}" for b, (f, _, _) in fits.items())),
        Assumption("reference_temperature", t0, "degC", f"reference temperature T0 = {t0:g} degC"),
        Assumption("valid_range", span, "degC",
                   f"valid range {span[0]:.4g} to {span[1]:.4g} degC (the plateau temperatures "
                   "widened by the settling tolerance)"),
        Assumption("settling", (window, rate_limit), "s, degC/min",
                   f"plateaus used when the sensor temperature changed less than "
                   f"{rate_limit:g} degC/min over the last {window:g} s of the soak"),
        Assumption("scatter", "birge", "",
                   "weights from the plateau tumbles (noise pooled over the plateaus); the "
                   "covariance scaled up by the Birge ratio squared only where the polynomial's "
                   "residuals scatter more than the weights say (" + ", ".join(
                       f"{b} R_B {f.birge:.3g}, {f.dof} dof" for b, (f, _, _) in fits.items())
                   + "); polynomials of different terms fitted separately (no cross-covariance)"),
        Assumption("hysteresis", tuple(hyst), "",
                   "heating-minus-cooling term fitted for " + ", ".join(hyst) if hyst else
                   "no hysteresis term: the plateaus were not approached from both sides"),
    ]
    if warm is not None:
        out.append(Assumption("warmup", "exponential", "",
                              "warm-up: y = c + a exp(-t/tau) at a fixed position after turn-on"))
    return tuple(out)
