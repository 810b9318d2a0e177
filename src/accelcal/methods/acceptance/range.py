"""Input range, clipped samples and recovery after overload (a centrifuge's ladder of inputs).

The dwell means ``m_i`` at inputs ``a_i`` (:mod:`~accelcal.methods.acceptance.dwells`)
give the bias ``b_i``, the mean of the last zero-input dwell before dwell
i (the centrifuge at rest), and the scale factor ``K1`` by weighted least
squares of ``m_i - b_i = K1 a_i`` over the dwells within ``linear_span`` g
(by default the third of the ladder nearest zero, both signs, no clipped
sample: with inputs of both signs the even nonlinearity does not bias
``K1``), and at each other input the nonlinearity relative to the input,

    n_i = (m_i - b_i - K1 a_i) / (K1 a_i).

On each side (positive and negative inputs, ascending ``|a|``), the input
range is the input where ``|n|`` first leaves the limit L: between the last
dwell inside (``a_1, n_1``) and the first outside (``a_2, n_2``), by
interpolation of ``log |n|`` in ``log |a|`` by the parabola through these
two dwells and the next one (a straight line in log-log is exact for a
nonlinearity growing as a power of the input, as a saturating rebalance
loop's does; the parabola follows a power that steepens; linear in ``n``
when a ``|n|`` is 0). The estimate is a smooth function of every dwell
mean (through the line too); the noise's part of its standard uncertainty
is propagated to first order with a numerical Jacobian, ``u_n^2 = sum_i
(d a* / d m_i)^2 se_i^2``; the interpolation's part is the difference
between the parabola's and the straight line's crossings, taken as the
half-width of a rectangular distribution, ``u_i = |a*_q - a*_l| /
sqrt(3)``; ``u^2 = u_n^2 + u_i^2``.

Clipped samples are found with :func:`accelcal.signal.clipping.clipped`
(runs at the record's ``rail`` when its metadata give one, else at the
recording's extremes). Recovery after overload: the bias at the first
zero-input dwell (before any overload) and at the last (after), in g, and
their difference with ``u = sqrt(se_before^2 + se_after^2) / |K1|``, its
z statistic and two-sided p-value.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, input range and overload recovery.
.. [IEEE836] IEEE Std 836-2009, precision centrifuge testing (ladder of inputs).
.. [GUM] JCGM 100:2008, 5.1.3 (law of propagation of uncertainty).
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np
from scipy.special import ndtr

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance.dwells import dwell_means
from accelcal.methods.acceptance.steps import FAMILY
from accelcal.results import Assumption, Estimate, Reduction
from accelcal.signal.clipping import clipped

METHOD = f"{FAMILY}/range"
LIMIT = 1e-3
"""Default nonlinearity limit, relative to the input (0.1 %)."""
SIDES = ((1.0, "range_pos"), (-1.0, "range_neg"))


def _line(a, m, se, fit, ref):
    """Bias at each dwell (its zero-input reference) and the weighted scale factor."""
    b = m[ref]
    w = a[fit] / se[fit] ** 2 if np.all(se[fit] > 0) else a[fit]
    return b, float(np.sum(w * (m[fit] - b[fit])) / np.sum(w * a[fit]))


def _crossing(a, n, limit, *, quadratic: bool = False):
    """The input where ``|n|`` first exceeds ``limit`` along ``a`` (ascending |a|).

    None when it never does, NaN when the first dwell already does. With
    ``quadratic``, ``log |n|`` is interpolated by the parabola in ``log |a|``
    through the bracketing dwells and the next one (when it exists).
    """
    out = np.flatnonzero(np.abs(n) > limit)
    if not out.size or out[0] == 0:
        return None if not out.size else np.nan
    j = out[0]
    (a1, a2), (n1, n2) = np.abs(a[j - 1:j + 1]), np.abs(n[j - 1:j + 1])
    if not (n1 > 0 and n2 > n1):
        return a1 + (limit - n1) * (a2 - a1) / (n2 - n1)
    la, ln = np.log(np.abs(a[j - 1:j + 2])), np.log(np.abs(n[j - 1:j + 2]))
    if quadratic and la.size == 3 and np.all(np.diff(ln) > 0):
        roots = np.roots(np.polyfit(la, ln, 2) - [0.0, 0.0, np.log(limit)])
        real = roots[np.isreal(roots)].real
        inside = real[(real >= la[0]) & (real <= la[1])]
        if inside.size:
            return float(np.exp(inside[0]))
    return np.exp(la[0] + (np.log(limit) - ln[0]) * (la[1] - la[0]) / (ln[1] - ln[0]))


def _ranges(m, setup, *, quadratic=False):
    """The crossing on each side for dwell means ``m``; ``setup`` the fixed arguments."""
    a, se, fit, ref, sides, limit = setup
    b, k1 = _line(a, m, se, fit, ref)
    out = []
    for _, order in sides:
        n = (m[order] - b[order] - k1 * a[order]) / (k1 * a[order])
        out.append(_crossing(a[order], n, limit, quadratic=quadratic))
    return np.array([np.nan if v is None else v for v in out], dtype=float)


def reduce_range(record, *, settle: float = 0.0, limit: float = LIMIT,
                 linear_span: float | None = None) -> Reduction:
    """Input range, clipped samples and overload recovery of a range record (module docs).

    Parameters
    ----------
    record : accelcal.io.formats.acceptance.StepRecord
        A ``range`` record.
    settle : float
        Seconds dropped at the start of each dwell.
    limit : float
        Nonlinearity limit, relative to the input.
    linear_span : float, optional
        Largest ``|input|`` (g) of the dwells the straight line is fitted to.

    Returns
    -------
    Reduction
        Method ``acceptance/range``; coefficients ``range_pos`` and/or
        ``range_neg`` (g, magnitudes), ``clipped_samples``,
        ``bias_before``, ``bias_after``, ``overload_shift`` (g).

    Raises
    ------
    AccelcalError
        For a record that is not a range test, no zero-input dwell before
        and after the largest input, too few dwells to fit the line, or no
        side whose nonlinearity leaves the limit within the ladder.
    """
    if record.test != "range":
        raise AccelcalError(f"a {record.test} record is not a range test")
    if not 0 < limit < 0.5:
        raise AccelcalError("the nonlinearity limit must be in (0, 0.5)", parameter="limit")
    rail = record.metadata.get("rail")
    clip = clipped(record.output, rails=None if rail is None else (-rail, rail))
    edges = record.dwells()
    clipped_dwell = np.add.reduceat(clip.mask, edges[:-1]) > 0
    dw = dwell_means(record, settle, pool=~clipped_dwell)
    a, m, se, k1_nominal = dw.input, dw.mean, dw.se, record.scale_factor
    zero = np.flatnonzero(a == 0.0)
    peak = int(np.flatnonzero(np.abs(a) == np.abs(a).max())[-1])
    if not (zero.size and zero[0] < peak < zero[-1]):
        raise AccelcalError("a range test needs zero-input dwells before the first and after "
                            "the last of its largest inputs (the bias before and after the "
                            "overload)")
    ref = np.maximum.accumulate(np.where(a == 0.0, np.arange(a.size), 0))
    span = linear_span if linear_span is not None else np.abs(a).max() / 3.0
    fit = (np.abs(a) <= span) & ~clipped_dwell & (a != 0.0)
    if np.unique(a[fit]).size < 2:
        raise AccelcalError(f"fewer than two unclipped non-zero inputs within {span:.3g} g to "
                            "fit the straight line: widen linear_span", parameter="linear_span")
    sides = []
    for sign, _ in SIDES:
        idx = np.flatnonzero(np.sign(a) == sign)
        _, first = np.unique(np.abs(a[idx]), return_index=True)
        sides.append((sign, idx[np.sort(first)] if idx.size else idx))
    sides = [(s, o[np.argsort(np.abs(a[o]))]) for s, o in sides]
    setup = (a, se, fit, ref, sides, limit)
    found = _ranges(m, setup, quadratic=True)
    u_interp = np.abs(found - _ranges(m, setup)) / np.sqrt(3.0)
    if np.isnan(found).all():
        raise AccelcalError(f"the nonlinearity stays within {limit:g} of the input up to "
                            f"{np.abs(a).max():.4g} g on both sides (or leaves it at the first "
                            "input): the range is not bracketed by the ladder")
    jac = np.zeros((2, m.size))
    for i in range(m.size):
        h = max(se[i], 1e-12 * max(abs(m[i]), 1.0))
        up, down = m.copy(), m.copy()
        up[i] += h
        down[i] -= h
        jac[:, i] = (_ranges(up, setup, quadratic=True)
                     - _ranges(down, setup, quadratic=True)) / (2 * h)
    u_noise = np.sqrt(np.sum((jac * se) ** 2, axis=1))
    u_range = np.hypot(u_noise, u_interp)
    k1 = k1_nominal
    before, after = zero[0], zero[-1]
    shift = (m[after] - m[before]) / k1
    u_shift = float(np.hypot(se[after], se[before]) / abs(k1))
    p_shift = float(2.0 * ndtr(-abs(shift) / u_shift)) if u_shift > 0 else float(shift == 0)
    keep = [i for i in range(2) if np.isfinite(found[i])]
    names = (*(SIDES[i][1] for i in keep), "clipped_samples", "bias_before", "bias_after",
             "overload_shift")
    values = np.r_[found[keep], clip.count, m[before] / k1, m[after] / k1, shift]
    var = np.r_[u_range[keep] ** 2, 0.0, (se[before] / k1) ** 2, (se[after] / k1) ** 2,
                u_shift**2]
    cov = np.diag(var)
    cov[-1, -3] = cov[-3, -1] = -((se[before] / k1) ** 2)
    cov[-1, -2] = cov[-2, -1] = (se[after] / k1) ** 2
    notes = [f"no input range on the {'positive' if i == 0 else 'negative'} side: the "
             f"nonlinearity stays within {limit:g} up to the largest input, or leaves it at "
             "the first" for i in range(2) if not np.isfinite(found[i])]
    z_shift = shift / u_shift if u_shift > 0 else (np.inf if shift else 0.0)
    if p_shift < 0.05:
        notes.append(f"the bias after the overload differs from the bias before by "
                     f"{shift * 1e6:.3g} ug (z {z_shift:.2f}, p {p_shift:.2g})")
    units = dict.fromkeys(names, "g") | {"clipped_samples": "1"}
    est = Estimate(names=names, values=values, covariance=cov, units=units, method=METHOD,
                   dof=dw.dof, notes=tuple(notes))
    return Reduction(
        family=FAMILY, method=METHOD, sensors=(est,), dof=dw.dof,
        assumptions=(
            Assumption("limit", limit, "1", f"nonlinearity limit {limit:g} of the input"),
            Assumption("linear_span", float(span), "g", f"straight line fitted to the "
                       f"unclipped dwells within {span:.3g} g"),
            Assumption("noise", "white", "", f"white output noise, {dw.sigma:.3g} "
                       f"{record.output_unit} per sample pooled over the dwells without clipped "
                       f"samples ({dw.dof} dof)"),
            Assumption("rail", rail, record.output_unit, "clipping at the record's rail"
                       if rail is not None else "clipping at the recording's extremes"),
        ),
        observations={"dwell_input": a, "dwell_mean": m, "dwell_se": se,
                      "dwell_clipped": clipped_dwell, "fit": fit},
        quantities={n: "bias" for n in names if n.startswith(("bias_", "overload"))},
        provenance={"test": "range", "output_unit": record.output_unit, "settle": settle,
                    "scale_factor": k1, "limit": limit, "shift_z": float(z_shift),
                    "shift_p": p_shift,
                    "line_scale_factor": _line(a, m, se, fit, ref)[1],
                    "range_u_noise_g": u_noise.tolist(), "range_u_interp_g": u_interp.tolist()},
    )
