"""The RQ split of a triad's sensitivity matrix and its first-order derivative.

Known orientations give, by linear least squares, the matrix ``A`` of
``u = A f + b`` (``f`` the specific force in the fixture frame). With the
model of :mod:`accelcal.methods.triad.model` and ``Q`` the fixture-to-body
rotation,

    A = K^-1 T^-1 Q = U Q

is an RQ decomposition: ``U = K^-1 T^-1`` upper triangular, ``Q``
orthogonal. It is unique once the diagonal of ``U`` is positive, so
``s_i = 1 / U_ii``, ``T^-1 = K U`` (unit diagonal) and the angles come
from ``T``. An orthogonal factor with determinant -1 (a triad left-handed
in the fixture frame: an axis wired reversed) is made proper by flipping the
axis whose flip brings ``Q`` closest to the identity; that axis's scale
factor is then negative.

Derivative: from ``dA = dU Q + U dQ`` with ``dQ = Omega Q`` (Omega skew, the
left perturbation ``Q -> (I + [omega]x) Q``), ``X = U^-1 dA Q'`` splits into
the upper-triangular ``U^-1 dU`` and the skew ``Omega``: the strictly lower
part of ``X`` is that of Omega, so

    Omega_ij = X_ij (i > j),  Omega_ji = -X_ij,  dU = U (X - Omega),
    ds_i = -dU_ii / U_ii^2,   d(T^-1) = dK U + K dU,   dT = -T d(T^-1) T.

Checked against finite differences of :func:`rq_split` in the tests.

References
----------
.. [GVL] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., 2013,
   sec. 5.2 (QR and its RQ variant; uniqueness with a positive diagonal).
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, eq. (8).
"""

import numpy as np

from accelcal.methods.triad.frames import angles_of


def rq_split(a) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``A = K^-1 T^-1 Q``: scale factors, angles, fixture-to-body rotation and ``U``.

    Returns
    -------
    scale : numpy.ndarray, shape (3,)
    angles : numpy.ndarray, shape (3,)
        (a_yz, a_zy, a_zx), rad.
    rotation : numpy.ndarray, shape (3, 3)
        ``Q``, proper.
    upper : numpy.ndarray, shape (3, 3)
        ``U = K^-1 T^-1``.
    """
    from scipy.linalg import rq

    upper, q = rq(np.asarray(a, dtype=float))
    sign = np.where(np.diag(upper) < 0, -1.0, 1.0)
    upper, q = upper * sign[None, :], q * sign[:, None]
    if np.linalg.det(q) < 0:
        i = int(np.argmin(np.diag(q)))  # flipping row i of Q raises its trace by -2 Q_ii
        upper[:, i] *= -1.0
        q[i] *= -1.0
    scale = 1.0 / np.diag(upper)
    t_inv = upper * scale[:, None]
    return scale, angles_of(np.linalg.inv(t_inv)), q, upper


def split_jacobian(a) -> np.ndarray:
    """``d (s, angles, omega) / d vec(A)`` (9 x 9, ``A`` row-major), first order."""
    scale, _, q, upper = rq_split(a)
    u_inv = np.linalg.inv(upper)
    t = np.linalg.inv(upper * scale[:, None])
    jac = np.empty((9, 9))
    for col in range(9):
        da = np.zeros(9)
        da[col] = 1.0
        x = u_inv @ da.reshape(3, 3) @ q.T
        omega = np.tril(x, -1)
        omega = omega - omega.T
        du = upper @ (x - omega)
        ds = -np.diag(du) / np.diag(upper) ** 2
        dt_inv = ds[:, None] * upper + scale[:, None] * du
        dt = -t @ dt_inv @ t
        jac[:, col] = np.concatenate([ds, angles_of(dt), [omega[2, 1], omega[0, 2], omega[1, 0]]])
    return jac
