"""Known orientations (six-position Ferraris, turntable, indexing head): least squares.

At position k the specific force in the fixture frame is known,
``f_k = g up_k`` (``up_k`` the unit gravity-opposing direction: a static
sensor feels ``+g up``). The readings are linear in it,

    u_k = A f_k + b,   A = K^-1 T^-1 Q                      # inverse of Eq. (1) [Tedaldi2014]

(``Q`` the fixture-to-body rotation). The noise is in the readings, so
``A`` and ``b`` are linear in the means (no errors-in-variables bias):
Ferraris's per-axis pairs on the six-position design, robust to a tilted
fixture, else (weighted) linear least squares of ``u_k,i`` on ``[f_k, 1]``
(:mod:`accelcal.methods.triad.pairs`). ``A`` is split by RQ
(:mod:`accelcal.methods.triad.split`) into ``s``, the angles and the gauge
``Q``. The covariance of the 12 linear coefficients is propagated to the 9
parameters and the 3 gauge angles to first order. With quadratic terms the
model is no longer linear: it is fitted by Levenberg-Marquardt on the
readings from the least-squares solution
(:func:`accelcal.methods.triad.forward.known_model`).

The noise variance is pooled over the three axes, from the residuals with
``3n - 12`` (``3n - 15`` with quadratic terms) degrees of freedom, unless
``noise_sd`` gives it (dof 0). A fixture tilt (``fixture_tilt``, a Type B
standard uncertainty [GUM]_) adds its covariance; the residuals are then
compared with what the noise and the tilt explain.

References
----------
.. [Ferraris1995] Ferraris F., Grimaldi U., Parvis M., Sensors and Materials
   7(5), 1995 (six positions, bias and sensitivity matrix).
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, eqs. (1), (8).
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., secs. 5.2-5.3.
.. [GUM] JCGM 100:2008, 4.3, 5.1.
"""

import dataclasses

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import analyse
from accelcal.methods.triad.common import (
    check_labels,
    check_means,
    check_noise,
    check_unit,
    common_assumptions,
    few_dof,
    relative_sd,
    spread_text,
)
from accelcal.methods.triad.forward import known_model, rotvec_matrix
from accelcal.methods.triad.pairs import (
    check_tilt,
    choose_estimator,
    design_matrix,
    linear_operator,
    tilt_blocks,
    tilt_covariance,
)
from accelcal.methods.triad.result import GAUGE, build_reduction
from accelcal.methods.triad.split import rq_split, split_jacobian
from accelcal.physics.gravity import check_gravity

METHOD = "triad/known-orientations"
"""Method name of a known-orientation calibration (records, store)."""

UP_TOL = 0.01
"""Largest departure of an ``up`` vector's norm from 1 accepted (then normalised)."""


def check_up(up, n: int) -> np.ndarray:
    """Unit gravity-opposing directions ``(n, 3)`` (norms within :data:`UP_TOL` of 1)."""
    try:
        arr = np.array(up, dtype=float)
    except (TypeError, ValueError):
        raise AccelcalError("must be unit vectors, shape (n, 3)", parameter="up") from None
    if arr.shape != (n, 3) or not np.isfinite(arr).all():
        raise AccelcalError(f"must be {n} finite unit vectors (one per position), shape "
                            f"({n}, 3); got {arr.shape}", parameter="up")
    norm = np.linalg.norm(arr, axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > UP_TOL)
    if bad.size:
        raise AccelcalError(f"row {int(bad[0])} has norm {norm[bad[0]]:.6g}; give unit vectors "
                            "(the direction opposite to gravity in the fixture frame)",
                            parameter="up")
    return arr / norm[:, None]


def _refuse(n: int, need: int, what: str, directions) -> None:
    gaps = spread_text(directions)
    raise AccelcalError(
        f"{n} position(s) given; at least {need} are needed {what}"
        + (f"; {gaps}" if gaps else "; the gravity directions lie in one plane or repeat")
        + " (six positions, each axis up and down, in practice)", parameter="up")


def _propagate(a, cov_lin) -> np.ndarray:
    """Covariance of (b, s, angles, omega) from that of (vec A, b) through the RQ split."""
    jac = np.zeros((12, 12))
    jac[0:3, 9:12] = np.eye(3)
    jac[3:12, 0:9] = split_jacobian(a)
    return jac @ cov_lin @ jac.T


def calibrate_known(means, up, gravity, *, input_unit="m/s^2", quadratic=False, labels=None,
                    counts=None, noise_sd=None, estimator=None, fixture_tilt=None):
    """Calibrate a triad from interval means at known orientations.

    Parameters
    ----------
    means : array_like, shape (n, 3)
        Interval means of the raw output, ``input_unit``.
    up : array_like, shape (n, 3)
        Unit gravity-opposing direction of each position in the fixture
        frame (``(1, 0, 0)``: x up, the x axis reading about +g).
    gravity : float
        Local gravity, m/s^2 (:func:`accelcal.physics.gravity.normal_gravity`).
    input_unit : str
        Unit of ``means``.
    quadratic : bool
        Fit the per-axis quadratic terms too.
    labels : sequence of str, optional
        Position labels (``x_p``, ...); default ``P1``...
    counts : array_like, shape (n,), optional
        Samples averaged in each mean: weights ``counts_k`` (white noise).
    noise_sd : float or array_like, optional
        SD of an interval mean (scalar, per axis (3,), per position (n,) or
        (n, 3)), input unit: the covariance then uses it (dof 0) instead of
        the residuals.
    estimator : {"least-squares", "pairs", "gls"}, optional
        The linear estimator (:mod:`accelcal.methods.triad.pairs`); default
        gls with a fixture tilt, else least squares.
    fixture_tilt : float, optional
        Standard uncertainty of each position's orientation about each
        horizontal axis, rad (Type B; linear model only, with ``noise_sd``):
        its covariance is added, and gls weighs the readings by it.

    Returns
    -------
    Reduction
        Family ``"triad"``, method :data:`METHOD`; one Estimate of the
        :data:`~accelcal.methods.triad.model.PARAMS` (and ``q_*``); ``shared``
        the gauge (rotation vector of the fixture-to-body rotation, rad);
        observations as :func:`accelcal.methods.triad.result.build_reduction`.

    Raises
    ------
    AccelcalError
        For malformed inputs, or positions that do not determine the model
        (naming how many were given, how many are needed and the directions
        no position visits).

    References
    ----------
    .. [1] Ferraris1995; Tedaldi2014 eqs. (1), (8); docs/triad.md.
    """
    u = check_means(means)
    n = u.shape[0]
    upv = check_up(up, n)
    g = check_gravity(gravity)
    unit = check_unit(input_unit)
    names_labels = check_labels(labels, n)
    noise = check_noise(noise_sd, n)
    tilt = check_tilt(fixture_tilt)
    if tilt is not None and (quadratic or noise is None):
        raise AccelcalError("the fixture tilt is weighed against the noise of the means in "
                            "the linear model: " + ("drop the quadratic terms" if quadratic
                                                    else "give noise_sd"),
                            parameter="fixture_tilt")
    sigma = noise if noise is not None else np.repeat(relative_sd(n, counts)[:, None], 3, 1)
    f = g * upv
    p_model = 12 if quadratic else 9
    need = (p_model + 3 + 2) // 3 + (0 if noise is not None else 1)
    if n < need:
        _refuse(n, need, "for this model" + ("" if noise is not None else
                                             " with residual degrees of freedom"), upv)
    design = analyse(np.column_stack([f, np.ones(n)]), ("f_x", "f_y", "f_z", "1"))
    if not design.full_rank:
        _refuse(n, max(need, 4), "with gravity directions not all in one plane", upv)
    kind = choose_estimator(estimator, upv, quadratic, tilt)
    lin = linear_operator(kind, f, sigma, upv, g, u=u, tilt=tilt)
    a, values, rot = estimate_known(u, f, sigma, quadratic, upv, estimator=kind, tilt=tilt)
    pred, jac = known_model(values, rot, f, quadratic)
    jw = (jac / sigma[:, :, None]).reshape(3 * n, -1)
    names = _names(quadratic)
    ident = analyse(jw, names)
    if quadratic and not ident.full_rank:
        _refuse(n, 18, "for the quadratic terms (each axis at three or more levels: many "
                "orientations spread over +-1 g)", upv)
    resid = u - pred
    dof = 3 * n - len(names)
    given = noise is not None
    var = 1.0 if given else float(np.sum((resid / sigma) ** 2) / dof)
    if quadratic:
        cov = var * np.linalg.inv(jw.T @ jw)
    else:
        cov_lin = var * (lin * sigma.ravel() ** 2) @ lin.T
        if tilt:
            cov_lin = cov_lin + tilt_covariance(lin, tilt_blocks(a, upv, g, tilt))
        cov = _propagate(a, cov_lin)
    assumptions = common_assumptions(g, noise, counts, quadratic, unit)
    assumptions += few_dof(dof, given)
    assumptions += _estimator_assumptions(kind, tilt)
    red = build_reduction(
        method=METHOD, values=values, covariance=cov, quadratic=quadratic, gauge=True,
        unit=unit, residuals=resid.ravel(), dof=dof, given=given, ident=ident,
        assumptions=assumptions, means=u, gravity=g, labels=names_labels, up=upv,
        rotation=rot.T, counts=counts, means_sd=sigma * np.sqrt(var))
    prov = {**red.provenance, "estimator": kind}
    notes = red.notes
    if tilt is not None:
        prov["fixture_tilt"] = tilt
        notes += (_tilt_note(resid, lin, f, sigma * np.sqrt(var), tilt_blocks(a, upv, g, tilt),
                             tilt=tilt),)
    return dataclasses.replace(red, provenance=prov, notes=notes)


def estimate_known(u, f, sigma, quadratic: bool, upv=None, *, estimator="least-squares",
                   tilt=None):
    """The estimates alone (no checks): A, values, rotation.

    ``values`` are b, s, angles (, q), omega = 0; ``rotation`` the
    fixture-to-body Q; ``estimator`` one of
    :data:`~accelcal.methods.triad.pairs.ESTIMATORS` (``upv`` is needed for
    pairs and gls; ``tilt`` for gls). Used by :func:`calibrate_known` and the
    Monte Carlo.
    """
    lin = linear_operator(estimator, f, sigma, upv, float(np.linalg.norm(f[0])), u=u, tilt=tilt)
    coef = lin @ u.ravel()
    a, b = coef[:9].reshape(3, 3), coef[9:]
    scale, angles, rot, _ = rq_split(a)
    values = np.concatenate([b, scale, angles, np.zeros(3) if quadratic else [], np.zeros(3)])
    if quadratic:
        values, rot = _quadratic_fit(values, rot, u, f, sigma, upv=upv)
    return a, values, rot


def _estimator_assumptions(kind: str, tilt) -> list:
    from accelcal.results import Assumption

    text = {"pairs": "per-axis pairs (Ferraris): a fixture tilt enters the biases at second "
                     "order",
            "gls": "generalised least squares weighing each reading by the noise and the "
                   "fixture tilt",
            "least-squares": "weighted least squares on all positions"}[kind]
    out = [Assumption("estimator", kind, "", f"estimator {kind}: {text}")]
    if tilt is not None:
        out.append(Assumption("fixture_tilt", tilt, "rad", f"fixture tilt {tilt:.3g} rad: Type "
                              "B standard uncertainty of each position's orientation about "
                              "each horizontal axis, independent between positions"))
    return out


def _tilt_note(resid, lin, f, sd, tilt_map, *, tilt: float) -> str:
    """How the residual RMS compares with what the noise and the stated tilt explain.

    The residuals are ``(I - D L) vec(u)`` (``D`` the design of the 12
    coefficients), so their expected mean square is ``tr(M C M') / 3n`` with
    ``M = I - D L`` and ``C`` the readings' covariance (noise plus tilt,
    block diagonal): computed in O(n) as ``tr C - 2 tr(D L C) + tr(L C L' D'D)``.
    """
    n = len(f)
    design = design_matrix(f)
    blocks = np.zeros((n, 3, 3))
    blocks[:, range(3), range(3)] = sd**2
    blocks += np.einsum("kij,klj->kil", tilt_map, tilt_map)
    lc = np.einsum("rkj,kjl->rkl", lin.reshape(12, n, 3), blocks).reshape(12, 3 * n)
    trace = (np.trace(blocks, axis1=1, axis2=2).sum() - 2.0 * np.einsum("rj,jr->", design, lc)
             + np.trace((lc @ lin.T) @ (design.T @ design)))
    expected = float(np.sqrt(max(trace, 0.0) / (3 * n)))
    rms = float(np.sqrt(np.mean(resid**2)))
    verdict = ("more than the noise and the stated tilt explain: the fixture may tilt more"
               if rms > 2.0 * expected else "consistent with them")
    return (f"residual RMS {rms:.3g} (input unit); the noise and a fixture tilt of "
            f"{tilt:.3g} rad explain {expected:.3g}: {verdict}")


def _names(quadratic: bool) -> tuple[str, ...]:
    from accelcal.methods.triad.model import PARAMS, QUADRATIC

    return PARAMS + (QUADRATIC if quadratic else ()) + GAUGE


def _quadratic_fit(values, rot, u, f, sigma, *, upv):
    """Levenberg-Marquardt on the readings from the linear solution; omega re-centred."""
    from scipy.optimize import least_squares

    def fun(x):
        return ((known_model(x, rot, f, True)[0] - u) / sigma).ravel()

    def jac(x):
        return (known_model(x, rot, f, True)[1] / sigma[:, :, None]).reshape(u.size, -1)

    sol = least_squares(fun, values, jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    if not sol.success or not np.isfinite(sol.x).all():
        _refuse(u.shape[0], 18, f"for the quadratic terms (the fit did not converge: "
                f"{sol.message})", upv)
    x = sol.x.copy()
    rot = rotvec_matrix(x[-3:]) @ rot
    x[-3:] = 0.0
    return x, rot
