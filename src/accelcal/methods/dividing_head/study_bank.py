"""Every sensor's exact model on the indexing head, for the Monte Carlo study.

:class:`SensorBank` evaluates the outputs of all sensors at angles
``theta + d`` for many trials at once (trials on the contiguous axis),
either exactly or, for small head errors, as a Taylor series in the head
error about ``d = 0`` so that only the variation is ever rounded.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (1)-(5).
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   eqs. (1)-(3) (the model).
"""

import numpy as np

TAYLOR_MAX_ORDER = 6
"""Highest power of the head error in the outputs' Taylor series (else exact evaluation)."""


def scratch(work: dict, name: str, shape: tuple) -> np.ndarray:
    """A reusable scratch array of ``shape`` (new only when the shape changes)."""
    arr = work.get(name)
    if arr is None or arr.shape != shape:
        arr = work[name] = np.empty(shape)
    return arr


def sin_cos_small(d: np.ndarray, work: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``sin d`` and ``cos d``: Taylor series when every ``|d| <= 1e-2`` rad, else numpy.

    Truncation after the ``d^7`` and ``d^6`` terms leaves at most
    ``|d|^9/9! < 3e-24`` and ``|d|^8/8! < 3e-21`` (far below one ulp of the
    result for any ``|d| <= 1e-2``); evaluation rounding stays within 2 ulp.
    ``work`` holds reusable scratch arrays.
    """
    work = {} if work is None else work
    d2 = np.multiply(d, d, out=scratch(work, "d2", d.shape))
    if d.size == 0 or not d2.max() <= 1e-4:
        return np.sin(d), np.cos(d)
    s, c = scratch(work, "sin_d", d.shape), scratch(work, "cos_d", d.shape)
    # Horner: s = d (1 - d2/6 (1 - d2/20 (1 - d2/42))), c = 1 - d2/2 (1 - d2/12 (1 - d2/30))
    np.multiply(d2, -1.0 / 42.0, out=s)
    np.multiply(d2, -1.0 / 30.0, out=c)
    for ks, kc in ((20.0, 12.0), (6.0, 2.0)):
        s += 1.0
        s *= d2
        s *= -1.0 / ks
        c += 1.0
        c *= d2
        c *= -1.0 / kc
    s += 1.0
    s *= d
    c += 1.0
    return s, c


class SensorBank:
    """Every sensor's model at once: outputs ``(K, n, T)`` at angles ``theta + d``.

    Parameters
    ----------
    models : sequence of ErrorModel
        One per sensor (a_p = 0 on the indexing head).
    theta : numpy.ndarray
        Each sensor's angle at each position without head error,
        ``alpha_j + phi_k + eta_k``, rad, shape ``(K, n)``.
    """

    def __init__(self, models, theta: np.ndarray):
        theta = np.asarray(theta, dtype=float)
        self.sin_theta, self.cos_theta = np.sin(theta)[..., None], np.cos(theta)[..., None]
        terms = {name: np.array([getattr(mod, name) for mod in models])[:, None, None]
                 for name in ("K0", "K1", "K2", "K3", "K4", "Ko", "Koo", "Kio",
                              "K0_asym", "K1_asym")}
        for group in (("K3", "K4"), ("Koo",), ("K0_asym", "K1_asym")):
            if not any(np.any(terms[name]) for name in group):
                for name in group:
                    del terms[name]
        self.model_terms = terms
        # Taylor series in the head error d of every output about d = 0: the outputs are
        # trigonometric polynomials of degree <= 4 in theta + d (Bernstein's inequality
        # bounds every derivative by degree**m times the largest output).
        self.degree = 4 if "K3" in terms else 2 if any(
            np.any(terms[name]) for name in ("K2", "Koo", "Kio") if name in terms) else 1
        taylor = self._taylor_coefficients(theta.astype(np.longdouble), TAYLOR_MAX_ORDER)
        self.offset = taylor[0]  # outputs at d = 0 without noise, (K, n), extended precision
        self.taylor = taylor[1:].astype(float)  # d**1 ... d**TAYLOR_MAX_ORDER, (order, K, n)
        # sgn(a_i) stays that of sin(theta) while |d| is below the distance to a zero of sin.
        asym = np.zeros(len(theta), bool)
        for name in ("K0_asym", "K1_asym"):
            if name in terms:
                asym |= terms[name][:, 0, 0] != 0.0
        self.sign_margin = float(np.min(
            np.abs(theta[asym] - np.pi * np.round(theta[asym] / np.pi)), initial=np.inf))

    def _taylor_coefficients(self, theta: np.ndarray, order: int) -> np.ndarray:
        """``c[m]`` with ``output(theta + d) = sum_m c[m] d**m``, shape ``(order + 1, K, n)``.

        Truncated power series (jets) through the same formula as
        :meth:`__call__` (sgn(a_i) taken as that of sin(theta)).
        """
        s, c = np.sin(theta), np.cos(theta)
        cycle_s, cycle_c = (s, c, -s, -c), (c, -s, -c, s)
        fact = np.cumprod(np.array([1.0, *range(1, order + 1)], dtype=theta.dtype))
        a_i = np.stack([cycle_s[m % 4] / fact[m] for m in range(order + 1)])  # sin(theta + d)
        a_o = np.stack([cycle_c[m % 4] / fact[m] for m in range(order + 1)])  # cos(theta + d)

        def mul(a, b):
            return np.stack([sum(a[i] * b[m - i] for i in range(m + 1)) for m in range(len(a))])

        def plus(a, const):
            out = a.copy()
            out[0] = out[0] + const
            return out

        t = {name: value[..., 0] for name, value in self.model_terms.items()}  # (K, 1)
        if "K3" in t:
            u = plus(a_i * t["K4"], t["K3"])
            u = plus(mul(u, a_i), t["K2"])
        else:
            u = np.zeros_like(a_i)
            u[0] = t["K2"]
        u = plus(mul(u, a_i), 1.0)
        u = plus(mul(u, a_i), t["K0"])
        if "Koo" in t:
            v = plus(a_o * t["Koo"], t["Ko"]) + t["Kio"] * a_i
        else:
            v = plus(t["Kio"] * a_i, t["Ko"])
        u = u + mul(v, a_o)
        if "K0_asym" in t:
            u = u + 0.5 * np.sign(s) * plus(a_i * t["K1_asym"], t["K0_asym"])
        return u * t["K1"]

    def taylor_order(self, d_max: float) -> int | None:
        """Terms needed beyond the constant for head errors ``|d| <= d_max``, or None.

        The smallest order ``r`` whose remainder bound ``(N d_max)^(r+1) / (r+1)!``
        (relative to the largest output; N the trigonometric degree) is below
        2**-60, far below one ulp; None when no order up to
        :data:`TAYLOR_MAX_ORDER` is enough or sgn(a_i) may change sign.
        """
        if not d_max < self.sign_margin:
            return None
        x, term = self.degree * d_max, 1.0
        for r in range(TAYLOR_MAX_ORDER + 1):
            term *= x / (r + 1)
            if term <= 2.0**-60:
                return r
        return None

    def outputs(self, d: np.ndarray, noise: np.ndarray, work: dict | None = None) -> np.ndarray:
        """Outputs ``(K, n, T)`` for head errors ``d`` ``(T, n)`` plus ``noise`` ``(T, K, n)``.

        :meth:`variation` plus :attr:`offset`; agrees with :meth:`__call__`
        (and the rig's model) to rounding.
        """
        return self.variation(d, noise, work) + self.offset.astype(float)[..., None]

    def variation(self, d: np.ndarray, noise: np.ndarray, work: dict | None = None,
                  noise_scale: np.ndarray | None = None) -> np.ndarray:
        """Outputs minus :attr:`offset` ``(K, n, T)`` (C-contiguous), as :meth:`outputs`.

        For head errors ``d`` ``(T, n)`` plus ``noise`` ``(T, K, n)``, times
        ``noise_scale`` ``(K,)`` (each sensor's noise SD) when given. By the
        Taylor series in ``d`` (:meth:`taylor_order`) when the head errors are
        small enough: the variation alone, never rounded at the outputs'
        magnitude, evaluated with the trials on the contiguous axis (the
        noise transposed and scaled in one pass). Otherwise the exact
        evaluation :meth:`__call__` minus the offset. ``work`` holds reusable
        scratch arrays.
        """
        work = {} if work is None else work
        order = self.taylor_order(max(float(d.max(initial=0.0)), -float(d.min(initial=0.0))))
        if order is None:
            if noise_scale is not None:
                noise = noise * noise_scale[:, None]
            u = self(d, noise, work)
            u -= self.offset.astype(float)[..., None]
            return u
        shape = (*self.offset.shape, d.shape[0])
        u = scratch(work, "u", shape)
        if noise_scale is None:
            np.copyto(u, noise.transpose(1, 2, 0))
        else:
            np.multiply(noise.transpose(1, 2, 0), noise_scale[:, None, None], out=u)
        if order:
            d_t = scratch(work, "d_t", d.shape[::-1])
            np.copyto(d_t, d.T)
            coef = work.get(("taylor", order))
            if coef is None:
                coef = work[("taylor", order)] = self.taylor[:order, ..., None]
            tay = scratch(work, "taylor_sum", shape)
            np.multiply(coef[order - 1], d_t, out=tay)
            for m in range(order - 1, 0, -1):  # Horner: d (c1 + d (c2 + ...))
                tay += coef[m - 1]
                tay *= d_t
            u += tay
        return u

    def __call__(self, d: np.ndarray, noise: np.ndarray, work: dict | None = None) -> np.ndarray:
        """Outputs ``(K, n, T)`` for head errors ``d`` ``(T, n)`` plus ``noise`` ``(T, K, n)``.

        The rig's exact model (:meth:`DividingHeadRig.outputs` with one
        reading) evaluated for all sensors at once, trials on the last
        (contiguous) axis, with ``sin`` and ``cos`` of ``theta + d`` from the
        angle-sum identities. ``work`` holds reusable scratch arrays.

        References
        ----------
        .. [1] Dong2014, eqs. (1)-(5); Guan2021, eqs. (1)-(3) (the model).
        """
        work = {} if work is None else work
        d_t = scratch(work, "d_t", d.shape[::-1])
        np.copyto(d_t, d.T)
        sd, cd = sin_cos_small(d_t, work)  # (n, T)
        st, ct = self.sin_theta, self.cos_theta  # (K, n, 1)
        shape = (*self.sin_theta.shape[:2], d.shape[0])
        tmp, a_i, a_o, u = (scratch(work, name, shape) for name in ("tmp", "a_i", "a_o", "u"))
        # In-place arithmetic throughout: large temporaries cost more than the flops.
        np.multiply(ct, sd, out=tmp)
        np.multiply(st, cd, out=a_i)
        a_i += tmp  # Eqs. (1)-(4) [Dong2014]: a_i = sin(theta + d)
        np.multiply(st, sd, out=tmp)
        np.multiply(ct, cd, out=a_o)
        a_o -= tmp  # a_o = cos(theta + d)
        c = self.model_terms
        # Eq. (2) [Guan2021], Horner in a_i, the same operations as ErrorModel.output_g
        # (terms zero for every sensor skipped: adding an exact zero changes nothing).
        if "K3" in c:
            np.multiply(a_i, c["K4"], out=u)
            u += c["K3"]
            u *= a_i
            u += c["K2"]
        else:
            u[:] = c["K2"]
        u *= a_i
        u += 1.0
        u *= a_i
        u += c["K0"]
        if "Koo" in c:
            np.multiply(c["Koo"], a_o, out=tmp)
            tmp += c["Ko"]
            tmp += c["Kio"] * a_i
        else:
            np.multiply(c["Kio"], a_i, out=tmp)
            tmp += c["Ko"]
        tmp *= a_o
        u += tmp
        if "K0_asym" in c:
            np.sign(a_i, out=tmp)  # Eq. (3) [Guan2021]
            tmp *= 0.5
            a_i *= c["K1_asym"]
            a_i += c["K0_asym"]
            tmp *= a_i
            u += tmp
        u *= c["K1"]
        u += noise.transpose(1, 2, 0)
        return u
