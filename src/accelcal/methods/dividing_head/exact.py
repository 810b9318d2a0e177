"""Exact indexing-head study: RMS errors and mean formal SDs without sampling.

Every method is linear in the readings (after each sensor's normalisation
by its fitted scale factor, which is ``K_I (1 + O(1e-5))``), so each error
is an affine function of the inputs the Monte Carlo study draws: the head
errors ``d``, the noise ``z`` of every reading and the first-harmonic
measurement error ``nu``. With ``J`` that map (built from the very operators
of :class:`~accelcal.methods.dividing_head.study_kernel.HeadStudy`) and the
inputs' mean and covariance,

- the mean error is ``J E[w] + b`` (``b`` the error of the noise-free fit,
  plus the mean of the head error's higher Taylor terms, ``E[d^m]``),
- the RMS error is ``sqrt(mean^2 + diag(J Cov J'))``: exact for any input
  distribution with these two moments, so for the uniform angle-error model
  (variance ``h^2 / 3``) as for Gaussian noise.

Each formal SD is ``sqrt(Q)`` (times constants), ``Q`` a quadratic form of
the inputs (a residual sum of squares, or four's weighted sum of them, plus
the first harmonic's term). Its mean is, for Gaussian inputs (exact),
``E|Q|^(1/2) = (2 pi)^(-1/2) int_0^inf (1 - Re phi(t)) t^(-3/2) dt`` with
``phi`` the characteristic function of ``Q`` in closed form [Imhof1961], one
smooth integral evaluated by the trapezoidal rule in ``log t``. Uniform
head errors enter the formal SDs as Gaussian errors of the same variance,
an approximation: where they dominate a method's residuals (``single``,
``four`` with Dong2014's 2 arcsec head) the mean formal SD differs from the
uniform model's by up to about 1 % (``tests/methods/dividing_head/test_dividing_head_exact.py``).
Four's formal SD pools the sensors' noise variances in a trial where an
unbiased one comes out negative (a few % of the trials); the closed form
takes the unpooled variances, within about 1 % of the study's mean.
Terms of second order in the noise over the outputs (``1e-5``) are left out.

References
----------
.. [Imhof1961] Imhof J. P., Computing the distribution of quadratic forms in
   normal variables, Biometrika 48 (1961) 419-426 (characteristic function).
.. [GUM-S1] JCGM 101:2008, 6.4.2 (rectangular distribution: variance h^2/3).
.. [DOMAIN] accelcal domain notes, section 4 (steps 0-7, joint least squares).
"""

import math

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.dividing_head import MAX_ANGLE_ERROR_RAD
from accelcal.methods.dividing_head.study import StudyResult, _applicable, _real
from accelcal.methods.dividing_head.study_kernel import HeadStudy

_LOG_SPAN = 24.0
"""Half width of the integration range in ``log t`` about ``-log E[Q]``: beyond it the
integrand is below 1e-10 of its peak, and the tail past the upper end is added exactly."""
_STEP = 0.05
"""Trapezoid step in ``log t`` (the integrand is smooth and decays at both ends)."""


def exact_study(rig, *, h1_sd: float = 0.0, methods=None) -> StudyResult:
    """RMS errors and mean formal SDs of the study in closed form (no sampling).

    Parameters
    ----------
    rig : DividingHeadRig
        As for :func:`~accelcal.methods.dividing_head.run_study`.
    h1_sd : float
        SD of the first-harmonic measurement given to the ``known_h1``
        methods, rad (0 ... 1 deg).
    methods : sequence of str, optional
        As for :func:`~accelcal.methods.dividing_head.run_study`.

    Returns
    -------
    StudyResult
        ``trials`` is 0 (no sampling); what a Monte Carlo study converges to.

    References
    ----------
    .. [1] [Imhof1961]; [GUM-S1] 6.4.2; [DOMAIN] section 4.
    """
    if not 0 <= _real(h1_sd) <= MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(f"must be a standard deviation >= 0 rad and at most 1 deg, got "
                            f"{h1_sd!r}", parameter="h1_sd")
    notes: tuple[str, ...] = ()
    if methods is None:
        methods, notes = _applicable(rig)
    study = HeadStudy(rig, tuple(methods), float(h1_sd))
    model = _Linear(study)
    rms = np.stack([model.rms(m) for m in study.methods])
    sd = np.stack([model.mean_sd(m) for m in study.methods])
    unit = rig.models[0].output_unit
    return StudyResult(study.methods, rms, sd, 0, unit,
                       (*notes, "exact: linearised methods, Gaussian formal-SD integrals"))


class _Linear:
    """The study's errors and residuals as affine maps of standard inputs ``xi``.

    ``xi`` = head errors (``n``), noise (``K n``), first-harmonic error (2), each
    with unit variance; ``u = u0 + U xi`` are the outputs' variations.
    """

    def __init__(self, study: HeadStudy):
        self.s = s = study
        rig, k, n = study.rig, study.k, study.n
        profile = rig.angle_error
        h = profile.half_width if profile.kind == "uniform" else 0.0
        d_mean = rig.angle_errors(1, None if h == 0 else np.random.default_rng(0))[0]
        if h:
            d_mean = np.asarray(study.h1_wave[0] + study.h1_wave[1])  # E[uniform] = 0
        d_sd = h / math.sqrt(3.0)  # Eq. (6.4.2) [GUM-S1]
        self.width = n + k * n + 2
        c1 = s.sensors.taylor[0]  # (K, n): d(output)/d(d)
        # u = c1 d + higher Taylor terms + sigma z / sqrt(repeats)
        u_xi = np.zeros((k, n, self.width))
        for j in range(k):
            u_xi[j, :, :n] = np.diag(c1[j]) * d_sd
            u_xi[j, :, n + j * n: n + (j + 1) * n] = np.eye(n) * (
                rig.noise[j] / math.sqrt(rig.repeats))
        moments = [_uniform_moment(d_mean, h, m + 1) for m in range(len(s.sensors.taylor))]
        self.u0 = sum(c * mom for c, mom in zip(s.sensors.taylor, moments, strict=True))  # (K, n)
        self.u_xi = u_xi
        self.d_mean = d_mean
        d_xi = np.zeros((n, self.width))
        d_xi[:, :n] = np.eye(n) * d_sd
        self.d_xi = d_xi
        nu_xi = np.zeros((2, self.width))
        nu_xi[:, -2:] = np.eye(2)
        self.nu_xi = nu_xi
        m = s.single_dof
        basis = s.single_op[:, 5:]  # (K, m, n)
        # normalised residual coordinates r = B u / K_I (K m)
        self.r0 = np.einsum("kmn,kn->km", basis, self.u0) / s.k_i0[:, None]
        self.r_xi = np.einsum("kmn,knw->kmw", basis, u_xi) / s.k_i0[:, None, None]
        self.r0, self.r_xi = self.r0.reshape(k * m), self.r_xi.reshape(k * m, self.width)
        self.four_cache: dict = {}  # four_unknown_h1 and four_known_h1 share forms

    def _affine_error(self, method: str):
        """Mean ``(K, 5)`` and map ``(K 5, width)`` of one method's error."""
        s, k = self.s, self.s.k
        est = s.single_op[:, :5]
        mean = np.einsum("kpn,kn->kp", est, self.u0) + s.base0
        mean[:, 2] -= s.coef[:, 1] * (s.gauge_proj[0] @ self.d_mean)
        xi = np.einsum("kpn,knw->kpw", est, self.u_xi)
        xi[:, 2] -= s.coef[:, 1, None] * (s.gauge_proj[0] @ self.d_xi)
        family = method.split("_", maxsplit=1)[0]
        if family != "single":
            f = s.families.index(family)
            rows = slice(f * s.q.shape[1], (f + 1) * s.q.shape[1])
            gain = s.x_gain[f] @ s.stage_op[rows]  # (5 K, K m): corrections from r
            scale = np.repeat(s.k_i0, 5)[:, None]
            mean += (scale[:, 0] * (gain @ self.r0)).reshape(k, 5)
            xi += (scale * (gain @ self.r_xi)).reshape(k, 5, self.width)
            if method.endswith("_known_h1"):
                h1 = s.h1_gain_all[f] * scale  # (5 K, 2)
                h1_mean = s.gauge_proj[1:] @ self.d_mean
                h1_xi = s.gauge_proj[1:] @ self.d_xi + s.h1_sd * self.nu_xi
                mean += (h1 @ h1_mean).reshape(k, 5)
                xi += (h1 @ h1_xi).reshape(k, 5, self.width)
        return mean, xi

    def rms(self, method: str) -> np.ndarray:
        mean, xi = self._affine_error(method)
        return np.sqrt(mean**2 + np.einsum("kpw,kpw->kp", xi, xi))

    def mean_sd(self, method: str) -> np.ndarray:
        """Mean formal SD ``(K, 5)`` of a method (Gaussian inputs)."""
        s, k, m = self.s, self.s.k, self.s.single_dof
        family = method.split("_", maxsplit=1)[0]
        r0, r_xi = self.r0.reshape(k, m), self.r_xi.reshape(k, m, self.width)
        out = np.empty((k, 5))
        if family == "single":
            for j in range(k):
                q = _Form.of([(1.0 / s.dof["single"], r0[j], r_xi[j])])
                out[j] = s.single_sd_unit[j] * s.k_i0[j] * q.mean_sqrt()
            return out
        extra = s.sd_extra[family] if method.endswith("_known_h1") else np.zeros((k, 5))
        if family == "joint":
            proj = np.eye(k * m) - s.q @ s.q.T
            form = _Form.of([(1.0 / s.dof["joint"], proj @ self.r0, proj @ self.r_xi)])
            plain = form.mean_sqrt()  # E sqrt(a Q) = sqrt(a) E sqrt(Q)
            for j in range(k):
                for p in range(5):
                    a = s.sd_unit["joint"][j, p] ** 2
                    value = (form.scaled(a, extra[j, p]).mean_sqrt() if extra[j, p]
                             else math.sqrt(a) * plain)
                    out[j, p] = s.k_i0[j] * value
            return out
        f = s.families.index("four")
        rows = slice(f * s.q.shape[1], (f + 1) * s.q.shape[1])
        resid = np.eye(k * m) - s.q @ s.stage_op[rows]  # four's residual r - q y
        e0, e_xi = (resid @ self.r0).reshape(k, m), (resid @ self.r_xi).reshape(k, m, -1)
        weights = (s.four_moments @ s.four_unbias).reshape(k, 5, k)  # var = W rss
        for j in range(k):
            for p in range(5):
                key = (j, p, float(extra[j, p]))
                if key not in self.four_cache:
                    form = _Form.of([(weights[j, p, i], e0[i], e_xi[i]) for i in range(k)])
                    self.four_cache[key] = form.scaled(1.0, extra[j, p]).mean_sqrt()
                out[j, p] = s.k_i0[j] * self.four_cache[key]
        return out


def _uniform_moment(mean: np.ndarray, h: float, m: int) -> np.ndarray:
    """``E[(mean + s)^m]`` for ``s`` uniform in ``[-h, h]`` (odd moments of s vanish)."""
    return sum(math.comb(m, j) * mean ** (m - j) * h**j / (j + 1) for j in range(0, m + 1, 2))


class _Form:
    """``Q = xi' H xi + 2 g' xi + c`` for standard normal ``xi``, in its eigenbasis."""

    def __init__(self, lam, shift, const, linear2):
        self.lam, self.shift, self.const, self.linear2 = lam, shift, const, linear2

    @classmethod
    def of(cls, terms) -> "_Form":
        """``Q = sum_i a_i |m_i + A_i xi|^2`` from ``(a_i, m_i, A_i)``."""
        h = sum(a * (x.T @ x) for a, _, x in terms)
        g = sum(a * (x.T @ m0) for a, m0, x in terms)
        c = sum(a * float(m0 @ m0) for a, m0, _ in terms)
        lam, vec = np.linalg.eigh(h)
        gp = vec.T @ g
        tol = 1e-12 * max(float(np.max(np.abs(lam))), 1e-300)
        big = np.abs(lam) > tol
        shift = np.where(big, gp / np.where(big, lam, 1.0), 0.0)
        const = c - float(np.sum(np.where(big, gp * shift, 0.0)))
        linear2 = float(np.sum(np.where(big, 0.0, gp**2)))
        return cls(lam[big], shift[big], const, linear2)

    def scaled(self, a: float, b: float) -> "_Form":
        """The form ``a Q + b``."""
        return _Form(self.lam * a, self.shift, self.const * a + b, self.linear2 * a * a)

    def mean(self) -> float:
        return float(np.sum(self.lam * (1.0 + self.shift**2))) + self.const

    def mean_sqrt(self) -> float:
        """``E|Q|^(1/2)`` by the characteristic function [Imhof1961]."""
        scale = self.mean()
        if not scale > 0:
            return 0.0
        s = np.arange(-_LOG_SPAN, _LOG_SPAN + _STEP / 2, _STEP) - math.log(scale)
        t = np.exp(s)[:, None]
        z = 1.0 - 2j * t * self.lam  # E exp(i t lam (eta + mu)^2) = z^-1/2 exp(i t lam mu^2 / z)
        log_phi = (np.sum(-0.5 * np.log(z) + 1j * t * self.lam * self.shift**2 / z, axis=1)
                   + 1j * t[:, 0] * self.const - 2.0 * t[:, 0] ** 2 * self.linear2)
        a, b = log_phi.real, log_phi.imag
        one_minus = -np.expm1(a) * np.cos(b) + 2.0 * np.sin(b / 2) ** 2  # 1 - Re phi
        f = one_minus * np.exp(-s / 2)
        integral = _STEP * (f.sum() - 0.5 * (f[0] + f[-1]))
        integral += 2.0 * math.exp(-s[-1] / 2)  # tail where phi ~ 0: int t^-3/2 dt
        return integral / math.sqrt(2.0 * math.pi)
