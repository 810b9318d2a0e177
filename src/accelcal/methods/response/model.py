"""The transfer-function model fitted to a measured frequency response, and what it gives.

The model is the force-rebalance accelerometer's closed loop of
:mod:`accelcal.physics.response`, second order with optionally an extra
real pole and a pure delay::

    S(f) = S0 wn^2 / (s^2 + 2 zeta wn s + wn^2) [1 / (1 + s / wp)] [exp(-s tau)],

``s = i 2 pi f``. :func:`fit_model` fits it to the complex points of a
stepped-sine reduction by weighted complex least squares: the residuals
``model - data`` are stacked as ``[Re, Im]`` pairs, each pair whitened by
the inverse Cholesky factor of the point's 2 x 2 covariance (of the whole
covariance where the points are correlated, as neighbouring bins of a
broadband response are), and solved by
:func:`scipy.optimize.least_squares` (trust region, from the best of a
grid of ``fn`` and ``zeta``). Where the points are averages of the response
over a kernel (the bins of a windowed spectrum: H1 of white excitation
expects ``sum_m k_m S(f + m df)``, ``k_m`` the window's squared spectrum at
whole bins [BP2010]_, for Hann ``1/6, 2/3, 1/6``), the model is averaged
alike, so that the curvature of the response near the resonance does not
bias ``fn`` and ``zeta``. The covariance of the parameters is
``(J'J)^-1`` of the whitened Jacobian at the solution (the points' own
covariances, not rescaled by the fit's chi-square: the Birge ratio is
reported beside). :func:`derived` evaluates the fitted model with
:func:`scipy.signal.freqs` and gives the -3 dB bandwidth, the resonance
(frequency and peak) and the phase at stated frequencies, with first-order
uncertainties (numerical gradients).

References
----------
.. [ISO16063-21] ISO 16063-21:2003 (complex sensitivity).
.. [Ogata2010] Ogata K., Modern Control Engineering, 5th ed., 2010, sec. 5-3
   and 8-2 (second-order systems: resonant peak, bandwidth).
.. [GUM] JCGM 100:2008, sec. 5.1.2 (law of propagation of uncertainty).
.. [BP2010] Bendat J. S., Piersol A. G., Random Data, 4th ed., 2010, sec. 8.5
   (the resolution bias of spectral density estimates: the curvature of the
   spectrum times the second moment of the analysis kernel).
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.physics.response import transfer
from accelcal.results import Assumption, Estimate, Reduction

METHOD = "response/model-fit"
"""Method id of the transfer-function fit."""

TERMS = ("pole", "delay")
"""Optional terms of the model beside ``second-order``."""

BANDWIDTH = "f_3dB"
"""The derived coefficient a fit's estimate carries after its parameters: the -3 dB
bandwidth, Hz (its records, and so the store's history, hold it)."""

RELATIVE_FLOOR = 1e-12
"""Floor of each point's standard uncertainty, relative to its magnitude: the rounding of
a noise-free record, so that its points (of zero stated variance) can still be weighted."""


def parse_model(text: str) -> tuple[str, ...]:
    """The optional terms of a model ``second-order[,pole][,delay]``.

    Raises
    ------
    AccelcalError
        For another model.
    """
    parts = [p.strip() for p in str(text).split(",")]
    if parts[0] != "second-order" or not set(parts[1:]) <= set(TERMS) or \
            len(set(parts[1:])) != len(parts) - 1:
        raise AccelcalError(f"{text!r} is not second-order[,pole][,delay]", parameter="model")
    return tuple(t for t in TERMS if t in parts[1:])


def parameter_names(terms) -> tuple[str, ...]:
    """``S0, fn, zeta`` and the terms' parameters ``pole`` (Hz) and ``delay`` (s)."""
    return ("S0", "fn", "zeta", *terms)


def evaluate(params, names, f) -> np.ndarray:
    """The model of parameters ``params`` (named ``names``) at frequencies ``f``, Hz."""
    p = dict(zip(names, params, strict=True))
    return transfer(f, p["S0"], p["fn"], p["zeta"], pole_hz=p.get("pole"),
                    delay_s=p.get("delay", 0.0))


class _Whitener:
    """Whitening by the Cholesky factor of the points' ``[Re, Im]`` covariance (with the floor).

    Per point (2 x 2 blocks) where the points are independent; where they
    are correlated (neighbouring bins of a broadband response) by the whole
    covariance, held as a band (its Cholesky factor is as narrow).
    """

    def __init__(self, values, covariance) -> None:
        from accelcal.polar import blocks

        floor = (RELATIVE_FLOOR * np.abs(values)) ** 2
        covariance = np.asarray(covariance, dtype=float) + np.kron(np.diag(floor), np.eye(2))
        rows, cols = np.nonzero(covariance)
        self.band = int(np.max(np.abs(rows - cols))) if rows.size else 0
        if self.band <= 1 and not np.any(covariance[1::2, 2::2]):
            self.blocks = np.linalg.inv(np.linalg.cholesky(blocks(covariance)))
            return
        from scipy.linalg import cholesky_banded

        n, b = covariance.shape[0], self.band
        lower = np.zeros((b + 1, n))
        for k in range(b + 1):
            lower[k, :n - k] = np.diagonal(covariance, -k)
        self.blocks = None
        self.factor = cholesky_banded(lower, lower=True)

    def __call__(self, pairs: np.ndarray) -> np.ndarray:
        """The whitened residuals of ``pairs`` (shape ``(m, 2)``), flattened."""
        if self.blocks is not None:
            return np.einsum("kij,kj->ki", self.blocks, pairs).ravel()
        from scipy.linalg import solve_banded

        return solve_banded((self.band, 0), self.factor, pairs.ravel())


def _kernel(observations):
    """``(offsets_hz, weights)`` of the points' averaging kernel, or None (point values)."""
    weights = observations.get("kernel")
    if weights is None:
        return None
    weights = np.asarray(weights, dtype=float)
    half = weights.size // 2
    return np.arange(-half, half + 1) * float(observations["bin_hz"]), weights


def _predict(x, names, f, kernel) -> np.ndarray:
    """The model at ``f``, averaged over the points' kernel where they have one."""
    if kernel is None:
        return evaluate(x, names, f)
    return sum(k * evaluate(x, names, f + off) for off, k in zip(*kernel, strict=True))


def _start(f, data, w, names, kernel) -> np.ndarray:
    """Best of a grid of ``fn`` and ``zeta`` (S0 from the lowest frequency; pole far, no delay)."""
    s0 = float(np.real(data[np.argmin(f)]))
    best, start = np.inf, None
    for fn in np.geomspace(f.min(), 30.0 * f.max(), 80):
        for zeta in (0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.5, 3.0):
            extra = [10.0 * f.max()] * ("pole" in names) + [0.0] * ("delay" in names)
            x = np.array([s0, fn, zeta, *extra])
            chi2 = np.sum(_residuals(x, names, f, data, w, kernel=kernel) ** 2)
            if chi2 < best:
                best, start = chi2, x
    return start


def _residuals(x, names, f, data, w, *, kernel) -> np.ndarray:
    d = _predict(x, names, f, kernel) - data
    return w(np.stack([d.real, d.imag], axis=1))


def fit_model(reduction, model: str = "second-order", *, start=None) -> Reduction:
    """Weighted complex least squares of the transfer function on a measured response.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A stepped-sine reduction (:func:`accelcal.methods.response.stepped.reduce_stepped`):
        complex points with their ``[Re, Im]`` covariance and ``frequency_hz``
        (and, for points averaged over a kernel, ``kernel`` and ``bin_hz``:
        a broadband reduction's).
    model : str
        ``second-order``, optionally with ``,pole`` and ``,delay``.
    start : sequence of float, optional
        The parameters (``S0, fn, zeta`` and the terms') to start from
        instead of the best of the grid: a fit of points near those of a
        known fit (the re-fits of a budget's perturbed points).

    Returns
    -------
    accelcal.results.Reduction
        Family ``response``, method ``response/model-fit``: ``S0`` (output unit
        per g), ``fn`` (Hz), ``zeta``, and ``pole`` (Hz), ``delay`` (s) where
        asked, then ``f_3dB`` (Hz, the -3 dB bandwidth the parameters give,
        where it is below 100 fn), with their joint covariance (the
        bandwidth's to first order); ``dof`` is ``2 m - p``; the assumption
        ``chi2`` gives the fit's chi-square and ``birge_ratio`` its square root
        per degree of freedom; observations ``frequency_hz`` and the points.

    Raises
    ------
    AccelcalError
        For fewer real data (2 per point) than parameters, or a fit that
        does not converge.

    References
    ----------
    .. [1] ISO 16063-21:2003; DOMAIN.md section 10.
    """
    from scipy.optimize import least_squares

    terms = parse_model(model)
    names = parameter_names(terms)
    est = reduction.estimate
    if not est.is_complex:
        raise AccelcalError("a model is fitted to a frequency response (complex points)",
                            parameter="reduction")
    f = np.asarray(reduction.observations["frequency_hz"], dtype=float)
    data = np.asarray(est.values)
    if 2 * f.size <= len(names):
        raise AccelcalError(f"{f.size} frequencies give {2 * f.size} real data, too few for "
                            f"the {len(names)} parameters of {model}", parameter="model")
    w = _Whitener(data, est.covariance)
    kernel = _kernel(reduction.observations)
    x0 = (_start(f, data, w, names, kernel) if start is None
          else np.asarray(start, dtype=float))
    lower = [-np.inf, 0.0, 0.0] + [0.0] * ("pole" in names) + [-np.inf] * ("delay" in names)
    scale = np.abs(x0) + np.array([0, 0, 0] + [0] * ("pole" in names) +
                                  [1e-6] * ("delay" in names))
    sol = least_squares(_residuals, x0, args=(names, f, data, w), kwargs={"kernel": kernel},
                        bounds=(lower, np.inf),
                        x_scale=scale, xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000,
                        jac="3-point")
    if sol.status <= 0:
        raise AccelcalError(f"the {model} fit did not converge ({sol.message})",
                            parameter="model")
    col = np.where(np.abs(sol.x) > 0, np.abs(sol.x), 1.0)  # equilibrated columns
    jac = sol.jac * col
    covariance = np.linalg.inv(jac.T @ jac) * np.outer(col, col)
    dof = 2 * f.size - len(names)
    chi2 = float(2.0 * sol.cost)
    unit = next(iter(est.units.values()))
    units = {"S0": unit, "fn": "Hz", "zeta": "1", "pole": "Hz", "delay": "s", BANDWIDTH: "Hz"}
    values, covariance, names = _with_bandwidth(sol.x, covariance, names)
    fitted = Estimate(names, values, covariance, {n: units[n] for n in names}, METHOD, dof=dof,
                      residuals=sol.fun)
    return Reduction(
        family=reduction.family, method=METHOD, sensors=(fitted,), sensor_names=("dut",),
        dof=0,
        assumptions=(
            Assumption("model", model, "", f"transfer function {model}"),
            Assumption("chi2", chi2, "", f"chi-square {chi2:.4g} on {dof} dof"),
            Assumption("birge_ratio", float(np.sqrt(chi2 / dof)) if dof else float("nan"), "",
                       "sqrt(chi2 / dof): about 1 where the model describes the points"),
            *(a for a in reduction.assumptions if a.name == "reference_frequency"),
        ),
        observations={"frequency_hz": f, "response": data, "covariance": est.covariance},
        provenance={"points": int(f.size), "unit": unit},
        notes=(("Weighted complex least squares of the transfer function; covariance from "
                "the points' own (not rescaled by the chi-square)."),),
    )


def _with_bandwidth(x, covariance, names):
    """The parameters and the -3 dB bandwidth after them, with their joint covariance.

    The bandwidth where the band reaches it, its covariance to first order:
    records, and so the store's history, then carry it.
    """
    f_hi = 100.0 * x[names.index("fn")]
    value = _bandwidth(x, names, f_hi)
    if not np.isfinite(value):
        return x, covariance, names
    grad = _gradient(lambda p: _bandwidth(p, names, f_hi), x, names)
    cov = np.zeros((x.size + 1, x.size + 1))
    cov[:-1, :-1] = covariance
    cov[:-1, -1] = cov[-1, :-1] = covariance @ grad
    cov[-1, -1] = max(float(grad @ covariance @ grad), 0.0)
    return np.append(x, value), cov, (*names, BANDWIDTH)


def _gradient(func, x, names) -> np.ndarray:
    """Central-difference gradient of ``func(x)`` (a scalar), steps relative to ``x``."""
    grad = np.zeros(x.size)
    for i in range(x.size):
        h = 1e-6 * max(abs(x[i]), 1e-9 if names[i] == "delay" else 1e-12)
        up, down = x.copy(), x.copy()
        up[i] += h
        down[i] -= h
        grad[i] = (func(up) - func(down)) / (2 * h)
    return grad


def _peak(x, names, f_hi) -> tuple[float, float]:
    """Frequency and height (ratio to |S0|) of the magnitude's maximum above 0, or NaNs."""
    from scipy.optimize import minimize_scalar

    grid = np.geomspace(f_hi * 1e-4, f_hi, 2000)
    mag = np.abs(evaluate(x, names, grid)) / abs(x[0])
    k = int(np.argmax(mag))
    if mag[k] <= 1.0 + 1e-9 or k in (0, grid.size - 1):
        return float("nan"), float("nan")
    res = minimize_scalar(lambda lf: -np.abs(evaluate(x, names, [np.exp(lf)]))[0],
                          bracket=(np.log(grid[k - 1]), np.log(grid[k]), np.log(grid[k + 1])),
                          tol=1e-12)
    return float(np.exp(res.x)), float(-res.fun / abs(x[0]))


def _bandwidth(x, names, f_hi) -> float:
    """The first frequency where |S| falls to |S0| / sqrt(2), or NaN below ``f_hi``."""
    from scipy.optimize import brentq

    grid = np.geomspace(f_hi * 1e-4, f_hi, 4000)
    g = np.abs(evaluate(x, names, grid)) / abs(x[0]) - 1.0 / np.sqrt(2.0)
    below = np.flatnonzero(g < 0)
    if below.size == 0 or below[0] == 0:
        return float("nan")
    k = below[0]
    return float(brentq(lambda fr: abs(evaluate(x, names, [fr])[0]) / abs(x[0])
                        - 1.0 / np.sqrt(2.0), grid[k - 1], grid[k], xtol=1e-14, rtol=1e-14))


def derived(fit: Reduction, phase_at=()) -> list[dict]:
    """The fitted model's -3 dB bandwidth, resonance and phases, with uncertainties.

    Parameters
    ----------
    fit : accelcal.results.Reduction
        A :func:`fit_model` result.
    phase_at : sequence of float
        Frequencies (Hz) at which to give the phase (deg, negative lagging).

    Returns
    -------
    list of dict
        Rows ``coefficient, estimate, std, unit``: ``f_3dB`` (Hz), ``f_peak``
        (Hz) and ``peak_dB`` (the resonance; NaN without one, zeta above
        about 0.707 for the plain second order), and ``phase(f Hz)`` (deg);
        standard uncertainties by first-order propagation of the parameters'
        covariance through numerical gradients [GUM]_.
    """
    bad = [f for f in phase_at if not (isinstance(f, int | float) and 0 < f <= 1e9)]
    if bad:
        raise AccelcalError(f"frequencies must be above 0 and up to 1e9 Hz, got {bad[0]!r}",
                            parameter="phase_at")
    est = fit.estimate
    keep = [k for k, n in enumerate(est.names) if n != BANDWIDTH]
    names = tuple(est.names[k] for k in keep)
    x, cov = np.asarray(est.values, float)[keep], est.covariance[np.ix_(keep, keep)]
    f_hi = 100.0 * x[names.index("fn")]
    quantities = [("f_3dB", "Hz", lambda p: _bandwidth(p, names, f_hi)),
                  ("f_peak", "Hz", lambda p: _peak(p, names, f_hi)[0]),
                  ("peak_dB", "dB", lambda p: 20.0 * np.log10(_peak(p, names, f_hi)[1]))]
    quantities += [(f"phase({f:g} Hz)", "deg",
                    lambda p, f=f: float(np.rad2deg(np.angle(evaluate(p, names, [f])[0]))))
                   for f in phase_at]
    rows = []
    for name, unit, func in quantities:
        value = func(x)
        std = float("nan")
        if np.isfinite(value):
            grad = _gradient(func, x, names)
            std = float(np.sqrt(max(grad @ cov @ grad, 0.0)))
        rows.append({"coefficient": name, "estimate": float(value), "std": std, "unit": unit})
    return rows


def fit_rows(fit: Reduction, phase_at=()) -> list[dict]:
    """What ``accelcal response fit`` prints: the parameters, then :func:`derived`."""
    est = fit.estimate
    rows = [{"coefficient": n, "estimate": float(v), "std": float(s), "unit": est.units[n]}
            for n, v, s in zip(est.names, est.values, est.std, strict=True) if n != BANDWIDTH]
    return rows + derived(fit, phase_at)
