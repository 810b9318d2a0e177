"""The linear estimators of a known-orientation calibration, and the fixture's tilt.

Both estimate the 12 coefficients of ``u_k = A f_k + b`` (``f_k = g up_k``)
as a linear map of the interval means, ``c = L vec(u)`` (``c``: ``A`` row by
row, then ``b``; ``vec(u)``: the means position by position), so the
covariance of the means propagates exactly, ``L Sigma L'``:

- ``least-squares``: per axis, weighted least squares of ``u_i`` on
  ``[f, 1]`` [GVL]_: any design that determines the model;
- ``pairs``: Ferraris's per-axis pairs [Ferraris1995]_ (as imucal computes
  them), for the six-position design (every ``up`` one of ``+-e_j``, each
  of the six present, repeats averaged): ``A e_j = (u_j+ - u_j-) / (2 g)``,
  ``b_j = (u_j+,j + u_j-,j) / 2``;
- ``gls``: generalised least squares [Aitken1935]_ with the readings'
  covariance from the noise of each mean and a stated fixture tilt (below),
  ``A`` in it from a first pass (pairs on six positions, else least
  squares). It is the best linear unbiased estimator under that model, and
  the tilt marginalised out of a joint fit of every position's small
  orientation error with a Gaussian prior: with no tilt it is least
  squares, with a tilt far above the noise it takes each bias from the
  readings of its own axis, as pairs do, and between the two it weighs
  them by what each reading knows.

Why pairs: a fixture held a small angle ``theta_k`` off its nominal
orientation feels ``f_k = g R(theta_k) up_k``. Axis ``j`` reads
``s_j g cos(theta) + b_j`` (plus cross-axis terms ``A_ji g theta``) when it
points up or down, so the mid-point of its own pair moves only at second
order, ``g theta^2 / 4``, and through the misalignments. Least squares
with equal weights takes every bias from the mean of all six means: at the
four positions where axis ``j`` is horizontal it reads ``s_j g theta_k +
b_j``, so a tilt of a few mrad enters the bias at first order (9.81 m/s^2 x
4 mrad = 0.04 m/s^2). In both, the columns of ``A`` take the tilt at first
order: with six positions a fixture tilt is not told apart from a
misalignment.

The tilt as a Type B input [GUM]_ (``fixture_tilt``: the standard
uncertainty of each position's orientation about each horizontal axis,
independent between positions): a small rotation ``omega_k`` turns
``up_k`` by ``omega_k x up_k``, which the estimator cannot tell from a
change of the readings ``A g (omega_k x up_k)``; with ``omega_k`` isotropic
its component across ``up_k`` has covariance ``sigma_t^2 P_k``, ``P_k = I -
up_k up_k'``, so the readings' covariance gains the block ``g^2 sigma_t^2 A
P_k A'`` and the coefficients ``L_k (g^2 sigma_t^2 A P_k A') L_k'`` summed
over the positions. At second order the force along ``up`` shortens by
``g |omega|^2 / 2``: its spread (SD ``g sigma_t^2``, 2.5e-4 m/s^2 at
5 mrad) is added along ``up`` as if Gaussian, ``g^2 sigma_t^4 A up_k
up_k' A'``; its mean (``g sigma_t^2`` at every position) looks like a
relative scale change of ``-sigma_t^2`` (25 ppm at 5 mrad) and is not
corrected.

References
----------
.. [Ferraris1995] Ferraris F., Grimaldi U., Parvis M., "Procedure for
   effortless in-field calibration of three-axis rate gyros and
   accelerometers", Sensors and Materials 7(5), 1995, eqs. (19)-(23).
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.3.
.. [Aitken1935] Aitken A. C., "On least squares and linear combination of
   observations", Proc. R. Soc. Edinburgh 55, 1935, 42-48.
.. [GUM] JCGM 100:2008, 4.3 (Type B evaluation), 5.1 (propagation).
"""

import numpy as np

from accelcal.errors import AccelcalError

ESTIMATORS = ("least-squares", "pairs", "gls")
"""The linear estimators of the known-orientation route."""

AXIS_TOL = 1e-6
"""An ``up`` vector is one of ``+-e_j`` (a pair's member) when its other components are
below this: a six-position design names the axis directions as such."""

MAX_TILT = 0.1
"""Largest fixture tilt accepted, rad (the propagation is first order in the angle)."""


def pair_sets(up) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """The positions with axis ``j`` up and down, for j = x, y, z; None unless six-position.

    Six-position: every ``up`` is one of ``+-e_j`` (within :data:`AXIS_TOL`)
    and each of the six directions is visited at least once.
    """
    upv = np.asarray(up, dtype=float)
    axis = np.argmax(np.abs(upv), axis=1)
    off = np.abs(upv).sum(axis=1) - np.abs(upv[np.arange(len(upv)), axis])
    if (off > AXIS_TOL).any():
        return None
    sign = np.sign(upv[np.arange(len(upv)), axis])
    sets = []
    for j in range(3):
        plus = np.flatnonzero((axis == j) & (sign > 0))
        minus = np.flatnonzero((axis == j) & (sign < 0))
        if not plus.size or not minus.size:
            return None
        sets.append((plus, minus))
    return sets


def choose_estimator(estimator, up, quadratic: bool, tilt) -> str:
    """The estimator to use: ``gls`` with a stated tilt, else least squares.

    An AccelcalError for an unknown name, or one where it does not apply.
    """
    if estimator is not None and estimator not in ESTIMATORS:
        raise AccelcalError(f"{estimator!r} is not one of {', '.join(ESTIMATORS)}",
                            parameter="estimator")
    six = pair_sets(up) is not None
    if estimator == "gls" and (quadratic or tilt is None):
        raise AccelcalError("gls weighs the readings by the noise and a stated fixture tilt "
                            "(linear model): give fixture_tilt"
                            + (" and drop the quadratic terms" if quadratic else ""),
                            parameter="estimator")
    if estimator == "pairs":
        if quadratic:
            raise AccelcalError("pairs estimates the linear model; the quadratic terms need "
                                "least-squares", parameter="estimator")
        if not six:
            raise AccelcalError("pairs needs the six-position design (every up vector one "
                                "of +-x, +-y, +-z, each of the six present); use "
                                "least-squares", parameter="estimator")
    if estimator is None:
        return "gls" if tilt is not None else "least-squares"
    return estimator


def design_matrix(f) -> np.ndarray:
    """``D`` (3n, 12): ``vec(u) = D c`` for the coefficients ``c`` (``A`` by rows, ``b``)."""
    n = len(f)
    design = np.zeros((3 * n, 12))
    for i in range(3):
        design[i::3, 3 * i:3 * i + 3] = f
        design[i::3, 9 + i] = 1.0
    return design


def linear_operator(estimator: str, f, sigma, up, gravity: float, *, u=None,
                    tilt=None) -> np.ndarray:
    """``L`` (12, 3n): the coefficients (``A`` row by row, then ``b``) from ``vec(u)``.

    ``sigma`` (n, 3) are the SDs of the means (relative: weights; absolute
    for ``gls``, which also needs the means ``u`` for its first pass and the
    ``tilt``, rad).
    """
    n = len(f)
    if estimator == "gls":
        first = "pairs" if pair_sets(up) is not None else "least-squares"
        a0 = (linear_operator(first, f, sigma, up, gravity) @ np.ravel(u))[:9].reshape(3, 3)
        blocks = tilt_blocks(a0, up, gravity, tilt)
        cov = np.einsum("kij,klj->kil", blocks, blocks)
        cov[:, range(3), range(3)] += sigma**2
        d = design_matrix(f).reshape(n, 3, 12)
        wd = np.linalg.solve(cov, d)  # W_k D_k
        normal = np.einsum("kij,kil->jl", d, wd)
        return np.linalg.solve(normal, wd.reshape(3 * n, 12).T)
    lin = np.zeros((12, 3 * n))
    w = 1.0 / sigma**2
    if estimator == "pairs":
        for j, (plus, minus) in enumerate(pair_sets(up)):
            for i in range(3):
                wp = w[plus, i] / w[plus, i].sum()
                wm = w[minus, i] / w[minus, i].sum()
                lin[3 * i + j, 3 * plus + i] = wp / (2.0 * gravity)
                lin[3 * i + j, 3 * minus + i] = -wm / (2.0 * gravity)
                if i == j:
                    lin[9 + j, 3 * plus + j] = wp / 2.0
                    lin[9 + j, 3 * minus + j] = wm / 2.0
        return lin
    x = np.column_stack([f, np.ones(n)])
    for i in range(3):
        sw = 1.0 / sigma[:, i]
        q, r = np.linalg.qr(x * sw[:, None])
        op = np.linalg.solve(r, q.T * sw[None, :])  # (4, n): theta_i = op @ u[:, i]
        lin[3 * i:3 * i + 3, i::3] = op[:3]
        lin[9 + i, i::3] = op[3]
    return lin


def check_tilt(fixture_tilt) -> float | None:
    """A fixture tilt (standard uncertainty, rad): finite, 0 to :data:`MAX_TILT`."""
    if fixture_tilt is None:
        return None
    try:
        value = float(fixture_tilt)
    except (TypeError, ValueError):
        value = float("nan")
    if isinstance(fixture_tilt, bool) or not 0.0 <= value <= MAX_TILT:
        raise AccelcalError(f"{fixture_tilt!r} must be an angle from 0 to {MAX_TILT:g} rad "
                            "(the standard uncertainty of each position's tilt)",
                            parameter="fixture_tilt")
    return value


def tilt_blocks(a, up, gravity: float, tilt: float) -> np.ndarray:
    """``B_k = g A (sigma_t P_k + sigma_t^2 up_k up_k')`` (n, 3, 3).

    The readings' tilt error is ``B_k z``, z ~ N(0, I) (module docs).
    """
    upv = np.asarray(up, dtype=float)
    along = upv[:, :, None] * upv[:, None, :]
    return gravity * np.einsum("ij,kjl->kil", a, tilt * (np.eye(3)[None] - along)
                               + tilt**2 * along)


def tilt_covariance(lin, blocks) -> np.ndarray:
    """Covariance (12, 12) of the coefficients from the tilt: ``sum_k L_k B_k B_k' L_k'``."""
    out = np.zeros((12, 12))
    for k, b in enumerate(blocks):
        lk = lin[:, 3 * k:3 * k + 3] @ b
        out += lk @ lk.T
    return out
