"""Joint least squares with one head-error unknown per position, linear in the readings.

The joint design ``[A | B]`` of the indexing head has a block of per-sensor
coefficient columns ``A`` (``K q`` columns) and one head-error column per
position whose rows are that position's readings only: ``B`` has disjoint
column supports, so ``B'B = diag(w)``. :func:`solve_arrow` eliminates the
head error position by position (the readings' part orthogonal to each
position's column, ``E = (I - B W^-1 B') A``) and keeps the gauge
constraint ``C'd = 0`` as ``c`` extra rows; the coefficients then come
from a ``K q``-column least-squares problem solved by a QR decomposition
accumulated over blocks of positions. Time is O(n (K q)^2), memory
O(n K q): no ``n x n`` or ``(K n) x (K n)`` matrix is formed.
:func:`design_identifiability` finds the rank, singular values and null
space of the unconstrained design the same way: with unit-norm head-error
columns (orthonormal, disjoint supports) every singular value but at most
``2 K q`` equals 1.

References
----------
.. [1] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., Johns
   Hopkins, 2013, secs. 5.3 (least squares by QR), 6.2 (equality-constrained
   least squares by elimination).
.. [DOMAIN] accelcal domain notes, section 4 (joint least squares, gauge freedom).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import (
    NULL_ATOL,
    RANK_RTOL,
    Combination,
    Identifiability,
    analyse,
    estimable_combinations,
    numerical_rank,
    small_svd,
)

BLOCK = 8192
"""Positions per block of the accumulated QR decomposition (bounds the work memory)."""


@dataclass(frozen=True)
class ArrowSolution:
    """Solution of :func:`solve_arrow` and the factors of its covariance (unit row variance).

    Attributes
    ----------
    x : numpy.ndarray, shape (K q, m)
        Coefficients, one column per right-hand side.
    d : numpy.ndarray, shape (n, m)
        Head errors (satisfying ``C'd = 0``).
    vx : numpy.ndarray, shape (K q, K q)
        Covariance of ``x`` per unit variance of the rows.
    pd : numpy.ndarray, shape (n, K q)
        ``Pi Dx``: ``Cov(x, d) = -vx pd'``.
    w_inv : numpy.ndarray, shape (n,)
        ``1 / w``.
    wc : numpy.ndarray, shape (n, c)
        ``W^-1 C``.
    mc : numpy.ndarray, shape (c, c)
        ``(C' W^-1 C)^-1``: ``Cov(d) = W^-1 - wc mc wc' + pd vx pd'``.
    """

    x: np.ndarray
    d: np.ndarray
    vx: np.ndarray
    pd: np.ndarray
    w_inv: np.ndarray
    wc: np.ndarray
    mc: np.ndarray

    def cov_xd(self) -> np.ndarray:
        """Covariance of ``x`` with ``d``, shape ``(K q, n)``."""
        return -self.vx @ self.pd.T

    def cov_d(self, *, dense: bool) -> np.ndarray:
        """Covariance of ``d``: ``(n, n)`` when ``dense``, else its diagonal ``(n,)``."""
        if dense:
            return np.diag(self.w_inv) - self.wc @ self.mc @ self.wc.T + \
                self.pd @ self.vx @ self.pd.T
        return self.w_inv - np.einsum("nc,cd,nd->n", self.wc, self.mc, self.wc) + \
            np.einsum("np,pq,nq->n", self.pd, self.vx, self.pd)


def solve_arrow(a, b, y, c, *, prior=None, names=None) -> ArrowSolution:
    """``min sum_kj (y_kj - a_kj . x_k - b_kj d_j)^2 + s^2 |d - r|^2`` subject to ``C'd = 0``.

    Parameters
    ----------
    a : numpy.ndarray, shape (K, n, q)
        Each sensor's coefficient rows (sensor k's coefficients are
        ``x[k q:(k + 1) q]``).
    b : numpy.ndarray, shape (K, n)
        How the head error at each position enters each reading.
    y : numpy.ndarray, shape (K, n, m)
        Readings, ``m`` right-hand sides.
    c : numpy.ndarray, shape (n, c)
        Gauge constraint ``C'd = 0``.
    prior : (float, numpy.ndarray of shape (n, m)), optional
        ``(s, r)``: pseudo-observations ``d ~ r`` of weight ``s`` (rows of
        unit variance after weighting), e.g. autocollimator readings.
    names : sequence of str, optional
        Names of the ``K q`` coefficients, for the identifiability check.

    Returns
    -------
    ArrowSolution

    Raises
    ------
    AccelcalError
        If a position's head error enters no reading, or the constrained
        problem does not determine the coefficients.
    """
    k, n, q = a.shape
    p = k * q
    y = np.asarray(y, dtype=float)
    m = y.shape[-1]
    w = np.einsum("kn,kn->n", b, b)
    rhs_d = np.einsum("kn,knm->nm", b, y)
    if prior is not None:
        s, r = prior
        w = w + s * s
        rhs_d = rhs_d + s * s * r
    if not (w > 0).all():
        j = int(np.argmin(w))
        raise AccelcalError(
            f"method joint: the head error at position {j} enters no reading (every sensor is "
            "at 90 deg to gravity's change there); the design is not identifiable"
        )
    w_inv = 1.0 / w
    t = (b[:, :, None] * a).transpose(1, 0, 2).reshape(n, p) * w_inv[:, None]  # Dx = W^-1 B'A
    g_y = rhs_d * w_inv[:, None]
    wc = c * w_inv[:, None]
    mc = np.linalg.inv(c.T @ wc)
    chol = np.linalg.cholesky(mc)  # L L' = (C'W^-1C)^-1: L' rows whiten C' g
    # Accumulated QR of [E | e_y] over blocks of positions, then the constraint rows.
    r_acc = np.zeros((0, p + m))
    for lo in range(0, n, BLOCK):
        hi = min(n, lo + BLOCK)
        rows = _eliminated(a, b, y, t, g_y, prior=prior, sl=slice(lo, hi))
        r_acc = np.linalg.qr(np.concatenate([r_acc, rows]), mode="r")
    rows = chol.T @ np.concatenate([c.T @ t, c.T @ g_y], axis=1)
    r_acc = np.linalg.qr(np.concatenate([r_acc, rows]), mode="r")
    r_x = r_acc[:p, :p]
    labels = names if names is not None else [f"x{i}" for i in range(p)]
    if r_x.shape[0] < p or analyse(r_x, labels).rank < p:
        raise AccelcalError("method joint: the coefficients are not determined")
    x = np.linalg.solve(r_x, r_acc[:p, p:])
    rinv = np.linalg.inv(r_x)
    vx = rinv @ rinv.T
    g = g_y - t @ x  # head errors without the constraint, given x
    d = g - wc @ (mc @ (c.T @ g))  # Pi g: the constraint enforced in the W metric
    pd = t - wc @ (mc @ (c.T @ t))
    return ArrowSolution(x, d, vx, pd, w_inv, wc, mc)


def _eliminated(a, b, y, t, g_y, *, prior, sl) -> np.ndarray:
    """Rows ``[E | e_y]`` of the positions ``sl`` (readings, then the prior's rows)."""
    k, _, q = a.shape
    p, m = k * q, y.shape[-1]
    nb = sl.stop - sl.start
    e = -b[:, sl, None] * t[None, sl]  # (K, nb, p): minus the head error's share
    for i in range(k):
        e[i, :, i * q:(i + 1) * q] += a[i, sl]
    ey = y[:, sl] - b[:, sl, None] * g_y[None, sl]
    out = np.concatenate([e, ey], axis=-1).reshape(k * nb, p + m)
    if prior is None:
        return out
    s, r = prior
    rows = np.concatenate([-s * t[sl], s * (r[sl] - g_y[sl])], axis=1)
    return np.concatenate([out, rows])


def design_identifiability(a, b, names, zero: float) -> Identifiability:
    """Rank, singular values and null space of the unconstrained joint design ``[A | B]``.

    Columns are equilibrated (unit norm, as :func:`accelcal.identifiability.analyse`
    does). The head-error columns then form an orthonormal set ``B_e``; with
    ``A_e = B_e T + E`` (``E`` orthogonal to them, ``E = Q_e R_e``) and the
    thin SVD ``T = U S V'``, the design is ``[B_e U, B_e U_perp, Q_e]`` times a
    matrix whose only non-identity block is ``[[S V', I], [R_e, 0]]``: its
    singular values are those of that small block and ones. O(n (K q)^2).

    Parameters
    ----------
    a : numpy.ndarray, shape (K, n, q)
    b : numpy.ndarray, shape (K, n)
    names : sequence of str
        ``K q`` coefficient names then ``n`` head-error names.
    zero : float
        Entries below this are rounded zeros (set to 0 before equilibrating).

    Returns
    -------
    accelcal.identifiability.Identifiability
        As :func:`~accelcal.identifiability.analyse` would return for the
        dense design (combinations in reduced row-echelon form).
    """
    k, n, q = a.shape
    p = k * q
    a = np.where(np.abs(a) < zero, 0.0, a)
    b = np.where(np.abs(b) < zero, 0.0, b)
    na = np.sqrt(np.einsum("knq,knq->kq", a, a)).reshape(p)
    nb = np.sqrt(np.einsum("kn,kn->n", b, b))
    sa, sb = np.where(na > 0, na, 1.0), np.where(nb > 0, nb, 1.0)
    ae = a / sa.reshape(k, 1, q)
    be = b / sb
    live = nb > 0
    t = (be[:, :, None] * ae).transpose(1, 0, 2).reshape(n, p)  # B_e' A_e
    r_e = np.zeros((0, p))
    for lo in range(0, n, BLOCK):
        sl = slice(lo, min(n, lo + BLOCK))
        e = -be[:, sl, None] * t[None, sl]
        for i in range(k):
            e[i, :, i * q:(i + 1) * q] += ae[i, sl]
        r_e = np.linalg.qr(np.concatenate([r_e, e.reshape(-1, p)]), mode="r")
    u, s, vt = np.linalg.svd(t[live], full_matrices=False)
    rr = s.size
    small = np.zeros((rr + r_e.shape[0], p + rr))
    small[:rr, :p] = s[:, None] * vt
    small[:rr, p:] = np.eye(rr)
    small[rr:, :p] = r_e
    sv_small, vt_small = small_svd(small)
    n_live = int(live.sum())
    sv = np.sort(np.concatenate([sv_small, np.ones(n_live - rr), np.zeros(n - n_live)]))[::-1]
    rank = numerical_rank(sv)
    tol = RANK_RTOL * sv[0] if sv.size else 0.0
    null_small = vt_small[sv_small <= tol].T  # (p + rr, .)
    null = np.zeros((p + n, null_small.shape[1] + n - n_live))
    null[:p, :null_small.shape[1]] = null_small[:p]
    d_live = np.flatnonzero(live)
    null[p + d_live, :null_small.shape[1]] = u @ null_small[p:]
    for i, j in enumerate(np.flatnonzero(~live)):
        null[p + j, null_small.shape[1] + i] = 1.0
    scale = np.concatenate([sa, sb])
    null = null / scale[:, None]
    norms = np.linalg.norm(null, axis=0)
    null = null / np.where(norms > 0, norms, 1.0)
    bad = np.abs(null).max(axis=1, initial=0.0) >= NULL_ATOL
    names = tuple(names)
    raw = np.concatenate([na, nb])
    return Identifiability(
        names=names, rank=rank, singular_values=tuple(float(v) for v in sv),
        identifiable=tuple(nm for nm, bd in zip(names, bad, strict=True) if not bd),
        unobservable=tuple(nm for nm, c in zip(names, raw, strict=True) if c == 0.0),
        null_space=null,
        combinations=tuple(Combination(wts)
                           for wts in estimable_combinations(null, names, bad)),
    )
