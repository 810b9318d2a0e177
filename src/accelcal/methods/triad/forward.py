"""The two observation models and their analytic Jacobians.

Known orientations (readings as functions of a known specific force):

    a_b = Q a_f,  w = T^-1 a_b,  p_i = 2 w_i / (1 + sqrt(1 + 4 q_i w_i)),  u_i = b_i + p_i / s_i

with ``Q`` the fixture-to-body rotation, perturbed on the left,
``Q -> exp([omega]x) Q`` (omega in rad, the gauge's three small angles; the
Jacobian is exact at omega = 0, where the fits evaluate their covariance).

Gravity norm (unknown orientations):

    p = s ⊙ (u - b),  w = p + q ⊙ p²,  a = T w,  r = |a| - g      # [Tedaldi2014] eq. (10)

Derivatives (``d(T^-1) = -T^-1 dT T^-1``; ``dT/da_yz = -e0 e1'``,
``dT/da_zy = e0 e2'``, ``dT/da_zx = -e1 e2'``) are written out below and
checked against finite differences in ``tests/methods/triad/test_triad_calibrate.py``.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, eqs. (8)-(10).
"""

import numpy as np

from accelcal.methods.triad.frames import t_matrix


def _skew(v: np.ndarray) -> np.ndarray:
    """``[v]x`` for every row of ``v`` ``(n, 3)``: shape ``(n, 3, 3)``."""
    z = np.zeros(v.shape[0])
    return np.stack([np.stack([z, -v[:, 2], v[:, 1]], -1),
                     np.stack([v[:, 2], z, -v[:, 0]], -1),
                     np.stack([-v[:, 1], v[:, 0], z], -1)], 1)


def rotvec_matrix(omega) -> np.ndarray:
    """The rotation matrix of rotation vector ``omega`` (Rodrigues' formula)."""
    omega = np.asarray(omega, dtype=float)
    theta = float(np.linalg.norm(omega))
    k = _skew(omega[None])[0]
    if theta < 1e-8:  # series to second order: rounding-exact below 1e-8 rad
        return np.eye(3) + k + 0.5 * k @ k
    return (np.eye(3) + np.sin(theta) / theta * k
            + (1.0 - np.cos(theta)) / theta**2 * k @ k)


def known_model(values, rotation, specific_force, quadratic: bool):
    """Predicted readings and their Jacobian for known specific forces.

    Parameters
    ----------
    values : array_like
        b (3), s (3), angles (3), then q (3) when ``quadratic``, then omega (3).
    rotation : numpy.ndarray, shape (3, 3)
        The fixture-to-body rotation ``Q0`` that omega perturbs.
    specific_force : numpy.ndarray, shape (n, 3)
        ``g up_k`` in the fixture frame, m/s^2.
    quadratic : bool

    Returns
    -------
    u : numpy.ndarray, shape (n, 3)
    jac : numpy.ndarray, shape (n, 3, P)
        ``du / d values``.
    """
    v = np.asarray(values, dtype=float)
    b, s, ang = v[0:3], v[3:6], v[6:9]
    q = v[9:12] if quadratic else np.zeros(3)
    omega = v[-3:]
    rot = rotvec_matrix(omega) @ rotation if np.any(omega) else rotation
    a_b = specific_force @ rot.T
    t_inv = np.linalg.inv(t_matrix(ang))
    w = a_b @ t_inv.T
    p = 2.0 * w / (1.0 + np.sqrt(1.0 + 4.0 * q * w))
    u = b + p / s
    n = w.shape[0]
    dpdw = 1.0 / (1.0 + 2.0 * q * p)
    dw = np.empty((n, 3, 6))  # d w / d (angles, omega)
    dw[:, :, 0] = t_inv[:, 0] * w[:, 1:2]
    dw[:, :, 1] = -t_inv[:, 0] * w[:, 2:3]
    dw[:, :, 2] = t_inv[:, 1] * w[:, 2:3]
    dw[:, :, 3:6] = -t_inv @ _skew(a_b)  # d a_b / d omega = -[a_b]x
    npar = 15 if quadratic else 12
    jac = np.zeros((n, 3, npar))
    for i in range(3):
        jac[:, i, i] = 1.0
        jac[:, i, 3 + i] = -p[:, i] / s[i] ** 2
        if quadratic:
            jac[:, i, 9 + i] = -p[:, i] ** 2 * dpdw[:, i] / s[i]
    tail = (dpdw / s)[:, :, None] * dw
    jac[:, :, 6:9] = tail[:, :, 0:3]
    jac[:, :, npar - 3:] = tail[:, :, 3:6]
    return u, jac


def norm_model(values, means, gravity: float, quadratic: bool):
    """Norm residuals ``|a_k| - g`` and their Jacobian ``(n, P)`` (P = 9 or 12)."""
    v = np.asarray(values, dtype=float)
    b, s, ang = v[0:3], v[3:6], v[6:9]
    q = v[9:12] if quadratic else np.zeros(3)
    t = t_matrix(ang)
    d = means - b
    p = s * d
    w = p + q * p * p
    a = w @ t.T
    norm = np.linalg.norm(a, axis=1)
    unit = a / norm[:, None]
    proj = unit @ t  # (n, 3): d-hat' T[:, i]
    gain = 1.0 + 2.0 * q * p
    cols = [-proj * gain * s, proj * gain * d,
            np.stack([-unit[:, 0] * w[:, 1], unit[:, 0] * w[:, 2], -unit[:, 1] * w[:, 2]], 1)]
    if quadratic:
        cols.append(proj * p * p)
    return norm - gravity, np.concatenate(cols, axis=1)


def norm_sd(values, means, noise: np.ndarray, quadratic: bool) -> np.ndarray:
    """SD of each norm residual from the SDs ``noise`` ``(n, 3)`` of the means (first order)."""
    v = np.asarray(values, dtype=float)
    b, s, ang = v[0:3], v[3:6], v[6:9]
    q = v[9:12] if quadratic else np.zeros(3)
    p = s * (means - b)
    a = (p + q * p * p) @ t_matrix(ang).T
    unit = a / np.linalg.norm(a, axis=1)[:, None]
    sens = (unit @ t_matrix(ang)) * (1.0 + 2.0 * q * p) * s  # d r / d u_i
    return np.sqrt(np.sum((sens * noise) ** 2, axis=1))
