"""The four-sensor reduction as factors linear in the number of positions (:class:`FourFactors`).

Every step of the corrected four-sensor reduction ([DOMAIN] section 4,
steps 1-4) is linear in the normalised outputs ``u_l = U_l / K_I,l``. The
separated head error is ``d_hi = sum_l D_l u_l`` with ::

    D_l = diag(g_l) + W Z_l'        (n x n, never formed for large n)

a diagonal plus a matrix of rank 11 (``W = [Q3, h23]``: the orthonormal
harmonics 0-3 removed in step 1 and the harmonics 2, 3 estimated in step
2), and sensor k's estimates are ``sum_l L_kl u_l`` with ``L_kl`` of shape
``5 x n``. Residual operators ``R_kl = (I - P_k)(delta_kl I - C_k D_l)``
are again diagonal plus low rank, so their Frobenius norms (the moments
that give each sensor's noise variance without bias) cost O(n), and so
does everything a reduction of measured data needs: estimates, residuals,
the propagated covariance of the coefficients (5K x 5K) and each
position's head-error variance. :meth:`FourFactors.dense` forms the
``(K n) x (K n)`` operators for the Monte Carlo paths, whose position
counts are small.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (15)-(31).
.. [DOMAIN] accelcal domain notes, section 4 (corrected reduction steps 0-7).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head.theory import alias_jacobian, harmonics, is_uniform, psi


def frobenius2(diag: np.ndarray, w: np.ndarray, z: np.ndarray) -> float:
    """``||diag(a) + W Z'||_F^2`` in O(n r^2) for ``W, Z`` of shape ``(n, r)``."""
    return float(diag @ diag + 2.0 * np.einsum("j,jr,jr->", diag, w, z)
                 + np.sum((w.T @ w) * (z.T @ z)))


def orthonormal(columns: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``(..., n, r)`` of the columns of ``(..., n, r)`` (thin QR)."""
    return np.linalg.qr(columns)[0]


@dataclass(frozen=True)
class FourFactors:
    """Low-rank factors of the four-sensor reduction for one design.

    Attributes
    ----------
    cos_beta : numpy.ndarray, shape (K, n)
        ``cos(beta_k)``: how the head error enters sensor k's normalised output.
    g : numpy.ndarray, shape (K, n)
        Diagonal of ``D_l``.
    w : numpy.ndarray, shape (n, 11)
        Column factor ``[Q3, h23]`` of ``D_l``.
    z : numpy.ndarray, shape (K, n, 11)
        Row factors ``Z_l`` of ``D_l``.
    pinv : numpy.ndarray, shape (K, 5, n)
        Each sensor's least-squares operator on ``Psi(beta_k)``.
    basis : numpy.ndarray, shape (K, n, 5)
        Orthonormal basis of ``Psi(beta_k)``.
    cov_unit : numpy.ndarray, shape (K, 5, 5)
        ``(Psi_k' Psi_k)^-1`` for step 7.
    alias : numpy.ndarray, shape (K, 5, 2)
        d(estimates)/d(d1c, d1s).
    """

    cos_beta: np.ndarray
    g: np.ndarray
    w: np.ndarray
    z: np.ndarray
    pinv: np.ndarray
    basis: np.ndarray
    cov_unit: np.ndarray
    alias: np.ndarray

    @classmethod
    def build(cls, positions, mounts) -> "FourFactors":
        """Factors for ``positions`` (uniform, n >= 12) and balanced ``mounts``.

        Raises
        ------
        AccelcalError
            If the positions are not equally spaced over the circle, fewer
            than 12, or the mounts do not cancel in V_z (sum exp(2 i phi) != 0).

        References
        ----------
        .. [1] Dong2014, eqs. (15)-(26), corrected as [DOMAIN] section 4,
           reduction steps 1-4.
        """
        alpha = np.asarray(positions, dtype=float)
        phi = np.asarray(mounts, dtype=float)
        n, k = alpha.size, phi.size
        if n < 12:
            raise AccelcalError(
                f"method four needs at least 12 equally spaced positions (harmonics up to 5 "
                f"of the head error are separated); got {n}"
            )
        if not is_uniform(alpha):
            raise AccelcalError(
                "method four needs equally spaced positions over the full circle; "
                "use method joint for other position sets"
            )
        if k < 2 or abs(np.exp(2j * phi).sum()) > 1e-9 * k:
            raise AccelcalError(
                "method four needs mounts whose doubled phases cancel (sum of exp(2i phi) = 0), "
                "e.g. 0,90,180,270 or 0,90 deg; use method joint for other mounts"
            )
        beta = alpha[None, :] + phi[:, None]
        cosb = np.cos(beta)
        c = 2.0 / k  # Eq. (17) [Dong2014], factor K/2 [DOMAIN]
        q3 = orthonormal(harmonics(alpha, 3))  # step 1 keeps harmonics >= 4 of V_z
        h23 = np.stack([np.cos(2 * alpha), np.sin(2 * alpha), np.cos(3 * alpha),
                        np.sin(3 * alpha)], axis=-1)
        fit1 = np.concatenate([harmonics(alpha, 2), h23 * cosb[0][:, None]], axis=-1)
        qf, rf = np.linalg.qr(fit1)
        f5 = np.linalg.solve(rf, qf.T)[5:]  # Eq. (21) [DOMAIN]: d2, d3 from sensor 1's fit
        f5c = f5 * cosb[0]
        f5cq = f5c @ q3
        z = np.empty((k, n, 11))
        for ell in range(k):
            # d(d_ge4)/du_l = c (C_l - Q3 Q3' C_l); d(d23)/du_l = F5 (delta_l0 I - C_0 d_ge4')
            z[ell, :, :7] = -c * (q3 * cosb[ell][:, None])
            d23 = -c * f5c * cosb[ell] + c * f5cq @ (q3.T * cosb[ell])
            if ell == 0:
                d23 = d23 + f5
            z[ell, :, 7:] = d23.T
        design = psi(beta)
        cov_unit = np.linalg.inv(np.swapaxes(design, -1, -2) @ design)
        pinv = cov_unit @ np.swapaxes(design, -1, -2)
        return cls(cosb, c * cosb, np.concatenate([q3, h23], axis=-1), z, pinv,
                   orthonormal(design), cov_unit, alias_jacobian(phi))

    @property
    def shape(self) -> tuple[int, int]:
        """(K, n)."""
        return self.cos_beta.shape

    def apply(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Step-4 estimates ``(K, 5)``, residuals ``(K, n)`` and ``d_hi`` ``(n,)`` of ``u``.

        References
        ----------
        .. [1] Dong2014, eqs. (15)-(29), corrected as [DOMAIN] section 4.
        """
        d_hi = np.einsum("kn,kn->n", self.g, u) + self.w @ np.einsum("knr,kn->r", self.z, u)
        v = u - self.cos_beta * d_hi  # Eq. (22) corrected [DOMAIN]
        coef = np.einsum("kpn,kn->kp", self.pinv, v)  # Eq. (24) [Dong2014]
        resid = v - np.einsum("knr,kr->kn", self.basis,
                              np.einsum("knr,kn->kr", self.basis, v))  # Eq. (29) [Dong2014]
        return coef, resid, d_hi

    def estimates_of(self, ell: int) -> np.ndarray:
        """``L_.l``: d(step-4 estimates of every sensor)/d(u_l), shape ``(5 K, n)``."""
        k, n = self.shape
        pc = self.pinv * self.cos_beta[:, None, :]  # P_k C_k, (K, 5, n)
        lin = -pc * self.g[ell] - (pc @ self.w) @ self.z[ell].T
        lin[ell] += self.pinv[ell]
        return lin.reshape(5 * k, n)

    def coefficient_moments(self) -> np.ndarray:
        """``M[i, l] = ||L_il||^2``: variance of estimate i per unit noise variance of sensor l."""
        k = self.shape[0]
        return np.stack([np.einsum("in,in->i", lin, lin)
                         for lin in map(self.estimates_of, range(k))], axis=-1)

    def residual_moments(self) -> np.ndarray:
        """``M_kl = ||R_kl||_F^2`` (K x K): E|r_k|^2 per unit noise variance of sensor l.

        ``R_kl = (I - Q_k Q_k')(delta_kl I - C_k D_l)`` is a diagonal plus a
        matrix of rank 16, so each norm costs O(n) (:func:`frobenius2`).
        """
        k, _ = self.shape
        out = np.empty((k, k))
        for kk in range(k):
            q = self.basis[kk]
            cw = self.w * self.cos_beta[kk][:, None]
            qcw = q.T @ cw
            left = np.concatenate([cw, q], axis=1)
            for ell in range(k):
                a = float(kk == ell) - self.cos_beta[kk] * self.g[ell]
                right = np.concatenate([-self.z[ell], self.z[ell] @ qcw.T - q * a[:, None]],
                                       axis=1)
                out[kk, ell] = frobenius2(a, left, right)
        return out

    def coefficient_covariance(self, variances) -> np.ndarray:
        """Covariance ``(5 K, 5 K)`` of the step-4 estimates for noise ``variances`` (K,)."""
        k = self.shape[0]
        cov = np.zeros((5 * k, 5 * k))
        for ell in range(k):
            lin = self.estimates_of(ell)
            cov += variances[ell] * (lin @ lin.T)
        return cov

    def angle_covariance(self, variances, *, dense: bool):
        """Covariance of ``d_hi``, and of the estimates with ``d_hi``.

        ``(n, n)`` and ``(5 K, n)`` when ``dense``; else the diagonal ``(n,)`` and None.
        """
        k, n = self.shape
        v = np.asarray(variances, dtype=float)
        diag_part = np.einsum("l,ln->n", v, self.g**2)
        cross = np.einsum("l,ln,lnr->nr", v, self.g, self.z)  # sum_l v_l G_l Z_l
        inner = np.einsum("l,lnr,lns->rs", v, self.z, self.z)
        if not dense:
            return diag_part + 2.0 * np.einsum("nr,nr->n", cross, self.w) + \
                np.einsum("nr,rs,ns->n", self.w, inner, self.w), None
        wc = cross @ self.w.T
        cov_d = np.diag(diag_part) + wc + wc.T + self.w @ inner @ self.w.T
        cov_xd = np.zeros((5 * k, n))
        for ell in range(k):
            lin = self.estimates_of(ell)
            cov_xd += v[ell] * (lin * self.g[ell] + (lin @ self.z[ell]) @ self.w.T)
        return cov_d, cov_xd

    def dense(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The dense ``(K n)``-column operators (Monte Carlo paths only: quadratic in n).

        Estimates ``(K, 5, K n)``, residuals ``(K, n, K n)`` and ``d_hi`` ``(n, K n)``.
        """
        k, n = self.shape
        angle = np.concatenate([np.diag(self.g[ell]) + self.w @ self.z[ell].T
                                for ell in range(k)], axis=1)
        coef = np.concatenate([self.estimates_of(ell) for ell in range(k)], axis=1)
        eye = np.eye(k * n).reshape(k, n, k * n)
        v = eye - self.cos_beta[:, :, None] * angle[None]
        resid = v - self.basis @ (np.swapaxes(self.basis, 1, 2) @ v)
        return coef.reshape(k, 5, k * n), resid, angle
