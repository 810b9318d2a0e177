"""The indexing-head reductions' first-order response to a change of the outputs.

The unestimated terms' alias matrix (:mod:`~accelcal.methods.dividing_head.unestimated`)
is the reduction applied to each term's output columns. The reductions are
linear in the outputs once normalised by each sensor's own scale factor
(``u_l = U_l / K_I,l``, [DOMAIN] step 0): the reported coefficients are
``theta_j = K_I,j x_j(u)`` with ``x`` affine in ``u``. A change ``dU_l`` of
sensor l's outputs changes ``K_I,l`` by ``dK_l = P_l dU_l`` (``P_l`` the sine
row of the single-sensor least-squares operator) and ``u_l`` by
``du_l = (dU_l - u_l dK_l) / K_I,l``, so that

    d theta_j = K_I,j (L du)_j + delta_jl dK_l x_j,

``L`` the linear part of the method. :func:`response` applies it to all
columns at once: one batched product (``four``: the factors' columns of
sensor l, :meth:`FourFactors.estimates_of`), one arrow solve with a
right-hand side per column (``joint``), or the tumble reduction of every
column as a trial (``tumble``, linear in the outputs in volts). ``single``
is linear in ``U`` itself. The result is the derivative, exact to rounding
(the central differences it replaces were exact only to ~1e-8 relative for
the normalised methods).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [DOMAIN] accelcal domain notes, section 4, steps 0-7.
.. [Montgomery] Montgomery D. C., Design and Analysis of Experiments, 8th
   ed., Wiley, 2013, sec. 10.3 (alias matrix).
"""

import numpy as np

from accelcal.methods.dividing_head.single import single_pinv
from accelcal.methods.dividing_head.theory import psi


def response(method: str, data, red, options: dict):
    """The linear response of ``method``'s coefficients to output columns, or None.

    Parameters
    ----------
    method : {"single", "four", "joint", "tumble"}
    data : HeadData
        The data ``red`` was reduced from.
    red : Reduction
        The reduction of ``data`` by ``method`` with ``options``.
    options : dict
        The options given to ``method``.

    Returns
    -------
    callable or None
        ``columns -> A``: ``columns`` a sequence of ``(sensor, z)`` with
        ``z`` of shape ``(n,)`` (an output change of that sensor), ``A`` of
        shape ``(K 5, len(columns))``, every sensor's coefficients
        (sensor-major) per column. None where the reduction is not linear
        in the normalised outputs (``joint`` with autocollimator readings,
        whose weight follows the residual scatter, or with Gauss-Newton
        iterations): the caller then differentiates numerically.
    """
    if method == "single":
        return _single(data)
    if method == "four":
        return _normalised(data, red, _four_linear(data))
    if method == "joint":
        if options.get("autocollimator") is not None or options.get("gauss_newton"):
            return None
        return _normalised(data, red, _joint_linear(data))
    if method == "tumble":
        return _tumble(data, red)
    return None


def _stack(data, columns) -> tuple[np.ndarray, np.ndarray]:
    """Sensors ``(q,)`` and output changes ``(q, n)`` of ``columns``."""
    sensors = np.array([k for k, _ in columns], dtype=int)
    z = np.array([np.asarray(col, dtype=float) for _, col in columns]).reshape(
        len(columns), data.positions.size)
    return sensors, z


def _single(data):
    """Each sensor's least squares on Psi(beta_k): linear in its own outputs."""
    pinv = single_pinv(data.angles())[0]  # (K, 5, n)

    def apply(columns):
        sensors, z = _stack(data, columns)
        k = data.n_sensors
        out = np.zeros((k, 5, len(columns)))
        for ell in np.unique(sensors):
            at = np.flatnonzero(sensors == ell)
            out[ell][:, at] = pinv[ell] @ z[at].T
        return out.reshape(5 * k, len(columns))

    return apply


def _normalised(data, red, linear):
    """Chain rule through the normalisation ``u_l = U_l / K_I,l`` of a linear method.

    ``linear(sensors, du)`` gives ``L du`` ``(K, 5, q)`` for normalised output
    changes ``du`` ``(q, n)``, column i on sensor ``sensors[i]``.
    """
    pinv = single_pinv(data.angles())[0]
    k_i = np.einsum("kn,kn->k", pinv[:, 1, :], data.outputs)
    u = data.outputs / k_i[:, None]
    x = np.array([e.values for e in red.sensors]) / k_i[:, None]  # (K, 5)

    def apply(columns):
        sensors, z = _stack(data, columns)
        dk = np.einsum("qn,qn->q", pinv[sensors, 1, :], z)
        du = (z - u[sensors] * dk[:, None]) / k_i[sensors, None]
        out = linear(sensors, du) * k_i[:, None, None]
        out[sensors, :, np.arange(len(columns))] += dk[:, None] * x[sensors]
        return out.reshape(5 * data.n_sensors, len(columns))

    return apply


def _four_linear(data):
    """``L du`` of the four-sensor reduction: its factors' columns of each sensor."""
    from accelcal.methods.dividing_head.factors import FourFactors

    fac = FourFactors.build(data.positions, data.mounts)
    k = data.n_sensors

    def linear(sensors, du):
        out = np.zeros((5 * k, len(sensors)))
        for ell in np.unique(sensors):
            at = np.flatnonzero(sensors == ell)
            out[:, at] = fac.estimates_of(ell) @ du[at].T
        return out.reshape(k, 5, len(sensors))

    return linear


def _joint_linear(data):
    """``L du`` of the linear joint least squares: one arrow solve, a right-hand side per column.

    The gauge values (mean error, first harmonic) enter the joint solution
    as constants; the solution is linear in ``du`` with the same constraint.
    """
    from accelcal.methods.dividing_head.arrow import solve_arrow
    from accelcal.methods.dividing_head.joint import gauge_columns

    beta = data.angles()
    a, b = psi(beta), np.cos(beta)
    c3 = gauge_columns(data.positions, True)
    k, n = beta.shape

    def linear(sensors, du):
        y = np.zeros((k, n, len(sensors)))
        y[sensors, :, np.arange(len(sensors))] = du
        return solve_arrow(a, b, y, c3).x.reshape(k, 5, len(sensors))

    return linear


def _tumble(data, red):
    """Each sensor's IEEE 1293 reduction about PA: the volts coefficients are linear in U.

    Every column is reduced as one more trial of the sensor's outputs
    (``U + z``, :func:`accelcal.methods.tumble.tumble_arrays`, the same
    route and terms as the reduction): the change of ``K_I``, ``K_I K_t``
    is the response, exact for the linear relations.
    """
    from accelcal.methods.tumble import tumble_arrays

    beta = data.angles()

    def apply(columns):
        sensors, z = _stack(data, columns)
        k = data.n_sensors
        out = np.zeros((k, 5, len(columns)))
        for ell in np.unique(sensors):
            at = np.flatnonzero(sensors == ell)
            arr = tumble_arrays(beta[ell], data.outputs[ell] + z[at], rotation_axis="PA",
                                output_unit=data.output_unit, asymmetry="auto")
            # a term not reported (or not identified) is taken as zero, as the reduction does
            v = {t: np.nan_to_num(arr.values[:, i]) for i, t in enumerate(arr.names)}
            v = {t: v.get(t, np.zeros(at.size)) for t in ("K0", "K1", "Ko", "Kio", "K2")}
            k1 = v["K1"]
            moved = np.stack([k1 * v["K0"], k1, k1 * v["Ko"], k1 * v["Kio"], k1 * v["K2"]])
            out[ell][:, at] = moved - red.sensors[ell].values[:, None]
        return out.reshape(5 * k, len(columns))

    return apply
