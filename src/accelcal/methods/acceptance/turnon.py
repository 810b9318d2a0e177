"""Turn-on repeatability: bias and scale factor from turn-on to turn-on, drift within a run.

In each turn-on j the dwell means ``m_i`` at inputs ``a_i`` (+1 g and -1 g)
and mid-times ``t_i`` are fitted by weighted least squares to

    m_i = beta_0 + beta_1 a_i + beta_2 (t_i - tbar_j),

so the turn-on's scale factor is ``k_j = beta_1``, its bias (g, at the
run's mean time ``tbar_j``) ``b_j = beta_0 / beta_1`` and its in-run drift
``d_j = beta_2 / beta_1`` (g/s), their uncertainties to first order from
the fit's covariance (the dwell means' standard errors). Across the N
turn-ons, the turn-on-to-turn-on repeatability is the sample standard
deviation of the ``b_j`` (ug) and of the ``k_j / mean(k)`` (ppm), with
N - 1 degrees of freedom; the 95 % interval of a standard deviation s is

    [s sqrt((N-1) / chi2_0.975(N-1)), s sqrt((N-1) / chi2_0.025(N-1))],

and its standard uncertainty ``s / sqrt(2 (N-1))`` (normal data). The
spread includes each turn-on's own measurement noise (the mean ``u(b_j)``
is stated beside it). The in-run drift is the mean of the ``d_j`` (ug/h)
with the standard error of that mean.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, turn-on to turn-on repeatability of bias
   and scale factor; in-run stability.
.. [GUM] JCGM 100:2008, G.3 and E.4.3 (uncertainty of a standard deviation).
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance.dwells import dwell_means
from accelcal.methods.acceptance.steps import FAMILY
from accelcal.results import Assumption, Estimate, Reduction

METHOD = f"{FAMILY}/turn-on"
MIN_TURN_ONS = 3
"""Fewest turn-ons a repeatability is computed from."""


def sd_interval(s: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """The ``level`` chi-square interval of a standard deviation ``s`` of ``n`` values."""
    from scipy.special import chdtri

    dof = n - 1  # chdtri(v, q): the chi-square quantile with upper-tail probability q
    return (float(s * np.sqrt(dof / chdtri(dof, 0.5 - level / 2))),
            float(s * np.sqrt(dof / chdtri(dof, 0.5 + level / 2))))


def _turn_on(a, t, m, se):
    """Bias (g), scale factor, drift (g/s) of one turn-on and their standard uncertainties."""
    x = np.column_stack([np.ones(a.size), a, t - t.mean()])
    w = 1.0 / se
    beta, *_ = np.linalg.lstsq(x * w[:, None], m * w, rcond=None)
    cov = np.linalg.inv((x * w[:, None] ** 2).T @ x)
    b0, k, d = beta
    jac = np.array([[1 / k, -b0 / k**2, 0.0], [0.0, 1.0, 0.0], [0.0, -d / k**2, 1 / k]])
    c = jac @ cov @ jac.T
    return np.array([b0 / k, k, d / k]), np.sqrt(np.diag(c))


def reduce_turn_on(record, *, settle: float = 0.0) -> Reduction:
    """Turn-on-to-turn-on repeatability and in-run drift of a turn-on record (module docs).

    Returns
    -------
    Reduction
        Method ``acceptance/turn-on``; coefficients ``bias_repeatability``
        (g), ``scale_repeatability`` (relative), ``drift`` (g/s), ``bias_mean``
        (g), ``bias_1`` ... (g) and ``scale_1`` ... (relative deviation from
        the mean); provenance ``bias_interval_g``, ``scale_interval``.

    Raises
    ------
    AccelcalError
        For a record that is not a turn-on test, fewer than three turn-ons,
        or a turn-on without two dwells at a positive and one at a negative
        input (bias, scale factor and drift need three dwells and both signs).
    """
    if record.test != "turn-on":
        raise AccelcalError(f"a {record.test} record is not a turn-on test")
    dw = dwell_means(record, settle)
    edges = record.dwells()
    label = record.turn_on[edges[:-1]]
    mid = 0.5 * (record.t[edges[:-1]] + record.t[edges[1:] - 1])
    runs = np.unique(label)
    if runs.size < MIN_TURN_ONS:
        raise AccelcalError(f"the record holds {runs.size} turn-on(s): a repeatability needs "
                            f"at least {MIN_TURN_ONS}")
    values, stds = [], []
    for j in runs:
        sel = label == j
        a = dw.input[sel]
        if sel.sum() < 3 or not (np.any(a > 0) and np.any(a < 0)):
            raise AccelcalError(f"turn-on {int(j)} has {sel.sum()} dwell(s): it needs at least "
                                "three, at a positive and a negative input, for its bias, scale "
                                "factor and drift")
        v, s = _turn_on(a, mid[sel], dw.mean[sel], dw.se[sel])
        values.append(v)
        stds.append(s)
    values, stds = np.array(values), np.array(stds)
    n = runs.size
    bias, scale, drift = values.T
    rel = scale / scale.mean() - 1.0
    s_b, s_k = float(np.std(bias, ddof=1)), float(np.std(rel, ddof=1))
    mean_drift = float(drift.mean())
    u_drift = float(np.std(drift, ddof=1) / np.sqrt(n))
    names = ("bias_repeatability", "scale_repeatability", "drift", "bias_mean",
             *(f"bias_{k + 1}" for k in range(n)), *(f"scale_{k + 1}" for k in range(n)))
    est_values = np.r_[s_b, s_k, mean_drift, bias.mean(), bias, rel]
    u_sd = 1.0 / np.sqrt(2.0 * (n - 1))
    var = np.r_[(s_b * u_sd) ** 2, (s_k * u_sd) ** 2, u_drift**2, s_b**2 / n,
                stds[:, 0] ** 2, (stds[:, 1] / scale.mean()) ** 2]
    units = {"bias_repeatability": "g", "scale_repeatability": "1", "drift": "g/s",
             "bias_mean": "g"} | {f"bias_{k + 1}": "g" for k in range(n)} | {
        f"scale_{k + 1}": "1" for k in range(n)}
    noise_b = float(np.sqrt(np.mean(stds[:, 0] ** 2)))
    notes = []
    if noise_b > 0.5 * s_b:
        notes.append(f"each turn-on's bias is measured to {noise_b * 1e6:.3g} ug, more than half "
                     f"the spread {s_b * 1e6:.3g} ug: longer dwells would separate them")
    est = Estimate(names=names, values=est_values, covariance=np.diag(var), units=units,
                   method=METHOD, dof=n - 1, notes=tuple(notes))
    return Reduction(
        family=FAMILY, method=METHOD, sensors=(est,), dof=n - 1,
        assumptions=(
            Assumption("turn_ons", n, "", f"{n} turn-ons; standard deviations with {n - 1} dof"),
            Assumption("model", "bias + K1 a + drift t", "", "per turn-on: bias, scale factor "
                       "and a linear in-run drift, by weighted least squares of the dwell means"),
            Assumption("noise", "white", "", f"white output noise, {dw.sigma:.3g} "
                       f"{record.output_unit} per sample pooled over the dwells ({dw.dof} dof)"),
            Assumption("turn_on_noise", noise_b, "g", "RMS uncertainty of one turn-on's bias, "
                       "included in the turn-on-to-turn-on spread"),
        ),
        observations={"turn_on": runs, "bias": bias, "bias_std": stds[:, 0], "scale": scale,
                      "scale_std": stds[:, 1], "drift": drift, "drift_std": stds[:, 2]},
        quantities={"bias_repeatability": "bias", "bias_mean": "bias"} | {
            f"bias_{k + 1}": "bias" for k in range(n)},
        provenance={"test": "turn-on", "output_unit": record.output_unit, "settle": settle,
                    "scale_factor": record.scale_factor, "turn_ons": int(n),
                    "bias_interval_g": sd_interval(s_b, n), "scale_interval": sd_interval(s_k, n)},
    )
