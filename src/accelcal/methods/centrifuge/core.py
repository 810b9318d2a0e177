"""The centrifuge reductions' solver: observation blocks, rig parameters, Gauss-Newton WLS.

Observations come in blocks (:class:`Block`): the centrifuge's step means,
and for a joint reduction the 1 g record's position means. Each block gives
the specific force of its observations as a function of the rig parameters
(the 1 g block's does not depend on them). The output of every observation
is linear in the output-unit coefficients ``b_t = K1 K_t``::

    y_k = sum_t b_t f_t(a_k(rho)) + e_k,   var(e_k) = sigma_g^2 / n_k        # Eq. (C1)

with ``n_k`` the readings averaged and ``sigma_g`` the noise of one reading
of block ``g``. :func:`solve` estimates ``b`` and the rig parameters marked
estimated by Gauss-Newton on the exact model (the rig enters through the
specific force only: its Jacobian is ``grad_a(sum b f) . da/drho``, with
``da/drho`` by central differences of the smooth geometry), weights each
block by its own residual variance (leverage-corrected, so unbiased), and
takes a given rig parameter with a standard uncertainty ``u`` (a survey) as
one more unknown with a pseudo-observation ``rho = v +- u`` (Eq. (C3)). Where
the records cannot see the parameter (a radius error beside K1 on the
centrifuge alone) this is exactly the propagation of ``u`` (Type B) ::

    cov = (A' W A)^-1 + G U G',   G = (A' W A)^-1 A' W J_given               # Eq. (C2)

and where they can, it combines the survey with the data instead of
forcing a value the data contradict (which would inflate the residuals and
count the survey's uncertainty twice).

The sign in the asymmetry terms, ``sgn(a_i)``, is taken at the nominal
set-up with the surveyed misalignments whose sign is certain (given with a
value more than :data:`SIGN_SIGMAS` SDs from zero; no other rig error;
Eq. (C4)), never at the estimates: a rig error of a few microradians must
not flip it between iterations (the idealised model's sgn is discontinuous
there). A position with IA perpendicular to the specific force (e.g. IA
tangential) and no such survey has ``a_i = 0`` there: its asymmetry's sign
is unknown, and :mod:`~accelcal.methods.centrifuge.unestimated` bounds it.

Everything is O(n p^2) in the observations (QR of the weighted design).

References
----------
.. [GUM] JCGM 100:2008, secs. 5.1 (law of propagation of uncertainty), 4.2.
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., 2013,
   secs. 5.3 (least squares by QR) and 5.6 (weighted).
.. [Nocedal] Nocedal J., Wright S. J., Numerical Optimization, 2nd ed.,
   2006, sec. 10.3 (Gauss-Newton).
.. [DOMAIN] accelcal domain notes, section 9.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import analyse
from accelcal.physics.centrifuge import (
    MISALIGNMENT_AXES,
    RIG_ERRORS,
    gradients,
    misaligned,
    regressors,
    specific_force,
)

SIGN_SIGMAS = 3.0
"""A surveyed misalignment sets the asymmetry's sign when its value is this many SDs from 0."""

MAX_ITERATIONS = 200
TOLERANCE = 1e-13
"""Gauss-Newton stops when every step is below this relative to its parameter's scale
(and the block weights have settled to the same level)."""

WEIGHT_TOLERANCE = 1e-6
"""The blocks' variances have settled when none changes by more than this (relative):
weights only set the efficiency, and a change of 1e-6 moves no estimate noticeably."""

VARIANCE_FLOOR = 1e-14
"""Least noise SD of a block, relative to its largest output: noise-free data (rounding
only) keep finite weights."""

_STEP = 1e-4
"""Relative central-difference step of da/drho: the geometry is linear in the radius
error, stretch and offset (exact), and in the misalignment the truncation error is
h^2/6 ~ 2e-9 of the derivative: a Jacobian, not a result."""


@dataclass(frozen=True)
class Block:
    """One group of observations with its own noise level.

    Attributes
    ----------
    name : str
        ``"centrifuge"`` or ``"1 g"``.
    y : numpy.ndarray, shape (n,)
        Observed mean outputs (output unit).
    count : numpy.ndarray, shape (n,)
        Readings averaged in each.
    c : numpy.ndarray or None, shape (n, 3, 3)
        Nominal orientations (centrifuge blocks).
    position : numpy.ndarray or None
        Position index of each observation.
    position_names : tuple of str
    rate2 : numpy.ndarray or None
        Mean squared rate, (rad/s)^2.
    radius, gravity : float
        m, m/s^2.
    fixed : tuple of numpy.ndarray or None
        ``(a_i, a_o, a_p)`` of a block that does not depend on the rig.
    level : numpy.ndarray or None
        Nominal level of each observation, g (centrifuge blocks; for figures).
    """

    name: str
    y: np.ndarray
    count: np.ndarray
    c: np.ndarray | None = None
    position: np.ndarray | None = None
    position_names: tuple = ()
    rate2: np.ndarray | None = None
    radius: float = 1.0
    gravity: float = 9.80665
    fixed: tuple | None = None
    level: np.ndarray | None = None

    def forces(self, rig: dict) -> tuple:
        """``(a_i, a_o, a_p)`` at rig parameters ``rig`` (name -> value; missing: 0)."""
        if self.fixed is not None:
            return self.fixed
        delta = np.array([[rig.get(f"misalignment:{p}:{ax}", 0.0) for ax in MISALIGNMENT_AXES]
                          for p in self.position_names])
        c = misaligned(self.c, delta[self.position]) if np.any(delta) else self.c
        return specific_force(c, np.sqrt(self.rate2), self.radius, gravity=self.gravity,
                              **{k: rig.get(k, 0.0) for k in RIG_ERRORS})

    def sensitivities(self, rig: dict, names) -> np.ndarray:
        """``da/drho`` of each named parameter, shape ``(3, n, m)`` (central differences)."""
        out = np.zeros((3, self.y.size, len(names)))
        if self.fixed is not None:
            return out
        for j, name in enumerate(names):
            h = _STEP * scale(name, self)
            up = np.array(self.forces({**rig, name: rig.get(name, 0.0) + h}))
            down = np.array(self.forces({**rig, name: rig.get(name, 0.0) - h}))
            out[:, :, j] = (up - down) / (2 * h)
        return out


def scale(name: str, block: Block | None = None) -> float:
    """A typical size of rig parameter ``name``: 1 (relative, rad), 1/max Omega^2, R0."""
    if name == "arm_stretch":
        top = float(np.max(block.rate2)) if block is not None and block.rate2 is not None else 1.0
        return 1.0 / max(top, 1e-12)
    if name == "proof_mass_offset":
        return block.radius if block is not None else 1.0
    return 1.0


@dataclass(frozen=True)
class Solution:
    """What :func:`solve` found (``b`` then the estimated rig parameters in ``z``)."""

    terms: tuple
    estimated: tuple
    z: np.ndarray
    cov: np.ndarray
    rig: dict
    residuals: tuple
    fitted: tuple
    sigma: np.ndarray
    dof: int
    design: np.ndarray
    iterations: int
    sign_at: dict
    estimator_design: np.ndarray
    """The weighted design of the final step with the given rig errors' columns and their
    pseudo-observations (Eq. (C3)) below: the estimator whose alias matrix
    :mod:`~accelcal.methods.centrifuge.unestimated` takes."""


def sign_rig(rig: dict, estimated=(), given_sd=None) -> dict:
    """The surveyed misalignments whose sign is certain (Eq. (C4)): name -> value."""
    given_sd = given_sd or {}
    return {k: v for k, v in rig.items() if k.startswith("misalignment:") and k not in estimated
            and v != 0.0 and abs(v) > SIGN_SIGMAS * given_sd.get(k, 0.0)}


def asymmetry_sign(blk: "Block", at: dict) -> np.ndarray:
    """``sgn(a_i)`` of a block at the nominal set-up with the misalignments ``at`` (Eq. (C4))."""
    a_i = blk.forces(at)[0]
    nominal = blk.forces({})[0]
    return np.where(np.abs(a_i) > 1e-12 * np.maximum(np.abs(nominal).max(), 1.0), np.sign(a_i),
                    0.0)


def design(blocks, terms, rig: dict, b, names, sign_at=None) -> tuple[np.ndarray, np.ndarray]:  # noqa: PLR0917
    """Regressors ``(N, p)`` of every block and the Jacobian ``(N, m)`` of ``names`` at ``b``.

    ``sign_at``: the misalignments that set the asymmetry's sign (:func:`sign_rig`).
    """
    phi, jac = [], []
    for blk in blocks:
        a = blk.forces(rig)
        sign = asymmetry_sign(blk, sign_at or {})  # Eq. (C4)
        phi.append(regressors(*a, terms, sign=sign))
        g = gradients(*a, terms, b, sign=sign)
        jac.append(np.einsum("nk,knm->nm", g, blk.sensitivities(rig, names)))
    return np.vstack(phi), np.vstack(jac)


def unit_coefficients(terms) -> np.ndarray:
    """``b`` of a unit sensor (K1 = 1, the rest 0): the first-order sensitivity."""
    return np.array([1.0 if t == "K1" else 0.0 for t in terms])


def solve(blocks, terms, rig: dict, estimated, given_sd: dict, *, sigma=None) -> Solution:
    """Gauss-Newton weighted least squares (Eqs. (C1), (C2)); see the module notes.

    Parameters
    ----------
    blocks : sequence of Block
    terms : tuple of str
    rig : dict
        Rig parameters' given values (and starting values of the estimated ones).
    estimated : tuple of str
        Rig parameters to estimate.
    given_sd : dict
        Standard uncertainty of given rig parameters (name -> SD > 0).
    sigma : float, optional
        Known noise SD of one reading (single block only); else estimated.

    Raises
    ------
    AccelcalError
        For a design that does not separate the unknowns, no degrees of
        freedom, or no convergence.
    """
    rig, given = dict(rig), dict(rig)
    at = sign_rig(given, estimated, given_sd)
    priors = tuple(k for k in given_sd if k not in estimated)
    free = (*estimated, *priors)
    y = np.concatenate([blk.y for blk in blocks])
    count = np.concatenate([blk.count for blk in blocks])
    groups = np.concatenate([np.full(blk.y.size, g) for g, blk in enumerate(blocks)])
    p, m, k, n = len(terms), len(estimated), len(priors), y.size
    for blk in blocks:
        if not np.any(blk.y):
            raise AccelcalError(f"the {blk.name} record's outputs are all zero: no response to "
                                "fit; check the output column")
    if n <= p + m and sigma is None:
        raise AccelcalError(f"{n} observations for {p + m} unknowns leave no degrees of freedom "
                            "to estimate the noise; add levels or positions, or estimate fewer "
                            "terms", parameter="terms")
    # weights on an absolute scale (block variances estimated) unless one block alone
    absolute = sigma is None and (len(blocks) > 1 or k > 0)
    var = np.ones(len(blocks)) if sigma is None else np.full(len(blocks), float(sigma) ** 2)
    floor = (VARIANCE_FLOOR * max(float(np.max(np.abs(y))), 1e-300)) ** 2
    prior_w = 1.0 / np.array([given_sd[nm] for nm in priors]) ** 2
    prior_rows = np.hstack([np.zeros((k, p + m)), np.eye(k)])
    b = unit_coefficients(terms)
    scales = np.array([scale(nm, blocks[0]) for nm in free])
    it = 0
    while it < MAX_ITERATIONS:
        it += 1
        phi, jac = design(blocks, terms, rig, b, free, at)
        a = np.vstack([np.hstack([phi, jac]), prior_rows])
        target = np.concatenate([y, [given[nm] - rig[nm] for nm in priors]])  # Eq. (C3)
        w = np.concatenate([count / var[groups], prior_w])
        q, r, rank = _qr(a, w)
        if rank < p + m + k:
            ident = analyse(a[:n, :p + m], (*terms, *estimated), sigma=1.0 / np.sqrt(w[:n]))
            raise AccelcalError(
                f"these records cannot separate {', '.join(ident.unidentifiable)} (rank "
                f"{ident.rank} of {p + m}); estimate fewer terms, give the rig errors from a "
                "survey, or add positions, levels or a 1 g record", parameter="terms")
        z = np.linalg.solve(r, q.T @ (target * np.sqrt(w)))
        step = z[p:] / scales
        b = z[:p]
        for nm, dz in zip(free, z[p:], strict=True):
            rig[nm] = rig.get(nm, 0.0) + dz
        resid = y - design(blocks, terms, rig, b, (), at)[0] @ b
        settled = True
        if absolute:
            lev = np.sum(q[:n] ** 2, axis=1)
            factor = _block_variances(resid, w[:n], lev, groups, len(blocks))
            new_var = np.maximum(var * factor, floor)
            settled = np.all(np.abs(new_var / var - 1.0) < WEIGHT_TOLERANCE)
            var = new_var
        if np.all(np.abs(step) < TOLERANCE) and settled:
            break
    else:
        raise AccelcalError(f"the reduction did not converge in {MAX_ITERATIONS} iterations: the "
                            "rig errors are too large for these records, or the records "
                            "disagree with the model (estimate more terms, e.g. the asymmetry)")
    phi, jac = design(blocks, terms, rig, b, free, at)
    fitted = phi @ b
    resid = y - fitted
    w = np.concatenate([count / var[groups], prior_w])
    full = np.vstack([np.hstack([phi, jac]), prior_rows])
    _, r, _ = _qr(full, w)
    rinv = np.linalg.inv(r)
    cov = (rinv @ rinv.T)[:p + m, :p + m]  # the priors' rig errors marginalised
    dof = n - p - m
    if sigma is None and not absolute:
        s2 = float(np.sum(w[:n] * resid**2) / dof)
        cov, var = cov * s2, var * s2
    splits = np.cumsum([blk.y.size for blk in blocks])[:-1]
    return Solution(
        terms=tuple(terms), estimated=tuple(estimated),
        z=np.concatenate([b, [rig[nm] for nm in estimated]]), cov=cov, rig=rig,
        residuals=tuple(np.split(resid, splits)), fitted=tuple(np.split(fitted, splits)),
        sigma=np.sqrt(var), dof=dof if sigma is None else 0,
        design=np.hstack([phi, jac[:, :m]]) * np.sqrt(w[:n])[:, None], iterations=it,
        sign_at=at, estimator_design=full * np.sqrt(w)[:, None])


def _qr(a, w):
    aw = a * np.sqrt(w)[:, None]
    q, r = np.linalg.qr(aw)
    rank = analyse(r, [str(k) for k in range(a.shape[1])]).rank
    return q, r, rank


def _block_variances(resid, w, lev, groups, k) -> np.ndarray:
    """Each block's variance factor ``sum w r^2 / (n_g - sum of its leverages)``."""
    rss = np.bincount(groups, weights=w * resid**2, minlength=k)
    eff = np.bincount(groups, minlength=k) - np.bincount(groups, weights=lev, minlength=k)
    if (eff <= 0.5).any():
        raise AccelcalError("a record has too few observations beyond the coefficients it "
                            "determines to estimate its noise; add readings or positions")
    return rss / eff
