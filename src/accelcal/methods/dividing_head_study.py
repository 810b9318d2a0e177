"""Monte Carlo study of the indexing-head reductions: actual error versus formal SD.

For a given truth (sensor models, mounts, misalignments), positions, head
angle-error profile, first harmonic and noise, many trials are simulated
and reduced by each method; for every method, sensor and coefficient the
study reports the RMS of the actual error and the mean of the formal
standard deviation the method itself reports. Where the two agree the
method's uncertainty is honest; where the RMS error is larger the formal
SD understates it.

Methods: ``single``, ``four_unknown_h1``, ``four_known_h1``,
``joint_unknown_h1``, ``joint_known_h1``. "Known" means the method is
given the realised first harmonic of the head error (plus a measurement
error of standard deviation ``h1_sd``, which it includes in its
covariance); "unknown" means it takes the first harmonic as zero.

The actual error is measured against the identifiable truth: K_F, K_I,
K_IO, K_II as simulated and ``K_O* = K_O + K_I (eta + d0)`` with d0 the
realised mean head error (no method can separate it, [DOMAIN] step 6).

The study runs on :func:`accelcal.montecarlo.run`: :class:`HeadStudy`
turns ``n`` trials drawn from a seed block's generator into one row of
outputs per trial (every error, plus the formal-SD factors), and the engine
keeps streaming means and RMS values. Results depend only on the rig, the
methods, ``h1_sd``, the seed and the block size: they are bit-identical
for any ``chunk``, in-process or on any number of Dask workers.

Vectorised: the designs are fixed, so every reduction is a precomputed
linear operator (after each sensor's normalisation by its own fitted scale
factor) applied to :data:`SUB_BLOCK` trials at once by matrix products,
trials on the contiguous axis. The outputs enter only as their variation
about the noise-free outputs at zero head error (a Taylor series in the
head error, :meth:`SensorBank.variation`), so nothing is rounded at the
outputs' magnitude; the constant part is fitted once in extended
precision. The single fit gives each sensor's estimates and orthonormal
residual coordinates (``n - 5`` numbers); ``four`` and ``joint`` differ from
it only by removing a head-error estimate whose effect lies in one small
subspace of those coordinates, so both act on a few projections of them.
There is no per-trial Python loop.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, section 3, Tables 1-2.
.. [DOMAIN] accelcal domain notes, section 4 (checks: formal SDs against
   Monte Carlo RMS errors).
"""

from dataclasses import dataclass

import numpy as np

from accelcal import montecarlo
from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head import (
    COEFFICIENTS,
    FourOperator,
    JointOperator,
    psi,
    single_operator,
)
from accelcal.rigs.dividing_head import DividingHeadRig

STUDY_METHODS = ("single", "four_unknown_h1", "four_known_h1", "joint_unknown_h1",
                 "joint_known_h1")

STUDY_BLOCK = 2**15
"""Default trials per seed block (part of a study's identity, with the seed)."""

SUB_BLOCK = 512
"""Trials drawn and reduced at once inside a seed block (part of the identity)."""

TAYLOR_MAX_ORDER = 6
"""Highest power of the head error in the outputs' Taylor series (else exact evaluation)."""
_TAYLOR_GROUP = 64



@dataclass(frozen=True)
class StudyResult:
    """Monte Carlo study result.

    Attributes
    ----------
    methods : tuple of str
        Method names (first axis).
    rms_error : numpy.ndarray
        RMS actual error, shape ``(methods, K, 5)``, output unit.
    mean_formal_sd : numpy.ndarray
        Mean formal SD, same shape.
    trials : int
        Number of trials.
    output_unit : str
        Unit of the outputs (coefficient units follow from it).
    notes : tuple of str
        Methods left out because the rig does not allow them, and why.
    """

    methods: tuple
    rms_error: np.ndarray
    mean_formal_sd: np.ndarray
    trials: int
    output_unit: str = "V"
    notes: tuple = ()

    def rows(self, per_sensor: bool = False) -> list[dict]:
        """Rows ``{method, coefficient, rms_error, mean_formal_sd}``.

        Averaged over sensors (RMS of the RMS errors, mean of the formal SDs)
        unless ``per_sensor``, which adds a ``sensor`` key.
        """
        rows = []
        for m, name in enumerate(self.methods):
            if per_sensor:
                for k in range(self.rms_error.shape[1]):
                    rows.extend(
                        {"method": name, "sensor": f"U{k + 1}", "coefficient": c,
                         "rms_error": float(self.rms_error[m, k, i]),
                         "mean_formal_sd": float(self.mean_formal_sd[m, k, i])}
                        for i, c in enumerate(COEFFICIENTS)
                    )
                continue
            rms = np.sqrt(np.mean(self.rms_error[m] ** 2, axis=0))
            sd = np.mean(self.mean_formal_sd[m], axis=0)
            rows.extend(
                {"method": name, "coefficient": c, "rms_error": float(rms[i]),
                 "mean_formal_sd": float(sd[i])}
                for i, c in enumerate(COEFFICIENTS)
            )
        return rows


def run_study(
    rig: DividingHeadRig,
    trials: int,
    seed=0,
    *,
    h1_sd: float = 0.0,
    chunk: int | None = None,
    methods=None,
    block_size: int = STUDY_BLOCK,
    workers: int | None = None,
    scheduler: str | None = None,
    progress=None,
    timeout: float = montecarlo.SCHEDULER_TIMEOUT_S,
) -> StudyResult:
    """Run the Monte Carlo study on :func:`accelcal.montecarlo.run`.

    Parameters
    ----------
    rig : DividingHeadRig
        Truth, positions, mounts, head error profile, first harmonic, noise.
        ``four`` methods need uniform positions (n >= 12) and balanced mounts.
    trials : int
        Number of trials (>= 2).
    seed : int
        Root seed (>= 0).
    h1_sd : float
        Standard deviation of the first-harmonic measurement given to the
        ``known_h1`` methods, rad (their covariance includes it).
    chunk : int, optional
        Trials per task, rounded up to whole seed blocks (default one
        block): scheduling and progress granularity. Does not change the
        result.
    methods : sequence of str, optional
        Subset of :data:`STUDY_METHODS`; by default every method the rig
        allows (``four`` needs uniform positions and balanced mounts,
        ``joint`` an identifiable design).
    block_size : int
        Trials per seed block. Part of the study's identity (with the seed):
        changing it changes which random numbers each trial gets.
    workers : int, optional
        Run on a Dask local cluster of this many worker processes.
    scheduler : str, optional
        Run on the Dask scheduler at this address (``tcp://host:8786``).
    progress : callable, optional
        ``progress(done, total)`` called as trials complete.
    timeout : float
        Seconds to wait for ``scheduler`` to answer.

    Returns
    -------
    StudyResult
        Bit-identical for any ``chunk``, ``workers`` or ``scheduler``.

    References
    ----------
    .. [1] [DOMAIN] section 4: formal SDs against Monte Carlo RMS errors.
    """
    if isinstance(trials, bool) or not isinstance(trials, (int, np.integer)) or trials < 2:
        raise AccelcalError(f"a study needs at least 2 trials, got {trials!r}")
    notes: tuple[str, ...] = ()
    if methods is None:
        methods, notes = _applicable(rig)
    methods = tuple(methods)
    bad = [m for m in methods if m not in STUDY_METHODS]
    if bad:
        raise AccelcalError(
            f"unknown study method(s) {bad}; choose from {', '.join(STUDY_METHODS)}"
        )
    if not np.isfinite(h1_sd) or h1_sd < 0:
        raise AccelcalError(f"h1_sd must be finite and >= 0 rad, got {h1_sd}")
    if chunk is not None and (isinstance(chunk, bool) or int(chunk) != chunk or chunk < 1):
        raise AccelcalError(f"chunk must be a positive number of trials, got {chunk!r}")
    study = HeadStudy(rig, methods, float(h1_sd))
    blocks_per_task = 1 if chunk is None else max(1, -(-int(chunk) // block_size))
    # Only means and RMS are needed: the engine keeps variances, not the p x p
    # covariance, and runs each task with one BLAS thread (the products are small).
    result = montecarlo.run(
        study, int(trials), names=study.names, seed=seed, block_size=block_size,
        blocks_per_task=blocks_per_task, covariance=False,
        workers=workers, scheduler=scheduler, progress=progress, timeout=timeout,
    )
    rms_error, mean_sd = study.summarise(result.rms, result.mean)
    unit = rig.models[0].output_unit
    return StudyResult(methods, rms_error, mean_sd, int(trials), unit, notes)


def _applicable(rig) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The study methods the rig's positions and mounts allow, and why others are left out."""
    methods, notes = ["single"], []
    for prefix, build in (("four", FourOperator.build), ("joint", JointOperator.build)):
        try:
            build(rig.positions, rig.mounts)
        except AccelcalError as exc:
            notes.append(f"{prefix} methods left out: {exc}")
            continue
        methods += [f"{prefix}_unknown_h1", f"{prefix}_known_h1"]
    return tuple(methods), tuple(notes)


def residual_basis(design: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``Q`` of the residual space of ``design`` ``(..., m, p)``.

    ``I - A A^+ = Q Q'``, so the residual sum of squares of data ``y`` is
    ``|Q' y|^2``: ``m - p`` numbers per record instead of ``m``.
    """
    p = design.shape[-1]
    q, _ = np.linalg.qr(design, mode="complete")
    return q[..., p:]


def _buffer(work: dict, name: str, shape: tuple) -> np.ndarray:
    """A reusable scratch array of ``shape`` (new only when the shape changes)."""
    arr = work.get(name)
    if arr is None or arr.shape != shape:
        arr = work[name] = np.empty(shape)
    return arr


def _sin_cos_small(d: np.ndarray, work: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``sin d`` and ``cos d``: Taylor series when every ``|d| <= 1e-2`` rad, else numpy.

    Truncation after the ``d^7`` and ``d^6`` terms leaves at most
    ``|d|^9/9! < 3e-24`` and ``|d|^8/8! < 3e-21`` (far below one ulp of the
    result for any ``|d| <= 1e-2``); evaluation rounding stays within 2 ulp.
    ``work`` holds reusable scratch arrays.
    """
    work = {} if work is None else work
    d2 = np.multiply(d, d, out=_buffer(work, "d2", d.shape))
    if d.size == 0 or not d2.max() <= 1e-4:
        return np.sin(d), np.cos(d)
    s, c = _buffer(work, "sin_d", d.shape), _buffer(work, "cos_d", d.shape)
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

    def variation(self, d: np.ndarray, noise: np.ndarray, work: dict | None = None) -> np.ndarray:
        """Outputs minus :attr:`offset` ``(K, n, T)``, as :meth:`outputs`.

        For head errors ``d`` ``(T, n)`` plus ``noise`` ``(T, K, n)``. By the
        Taylor series in ``d`` (:meth:`taylor_order`) when the head errors are
        small enough: the variation alone, never rounded at the outputs'
        magnitude, evaluated trials-first and returned as a transposed view.
        Otherwise the exact evaluation :meth:`__call__` minus the offset.
        ``work`` holds reusable scratch arrays.
        """
        work = {} if work is None else work
        order = self.taylor_order(max(float(d.max(initial=0.0)), -float(d.min(initial=0.0))))
        if order is None:
            u = self(d, noise, work)
            u -= self.offset.astype(float)[..., None]
            return u
        t, shape = d.shape[0], (d.shape[0], *self.offset.shape)
        u = _buffer(work, "u_tf", shape)
        if order:
            d_rep = _buffer(work, "d_rep", shape)
            np.copyto(d_rep, d[:, None, :])
            # Coefficients repeated over _TAYLOR_GROUP trials, broadcast over groups of
            # trials: long contiguous inner loops, and small enough to stay in cache.
            group = _TAYLOR_GROUP if t % _TAYLOR_GROUP == 0 else 1
            coef = work.get(("taylor", order, group))
            if coef is None:
                coef = work[("taylor", order, group)] = np.repeat(
                    self.taylor[:order, None], group, axis=1).reshape(order, 1, -1)
            ug, dg = u.reshape(t // group, 1, -1), d_rep.reshape(t // group, 1, -1)
            np.multiply(coef[order - 1], dg, out=ug)
            for m in range(order - 1, 0, -1):  # Horner: d (c1 + d (c2 + ...))
                ug += coef[m - 1]
                ug *= dg
            u += noise
        else:
            np.copyto(u, noise)
        return u.transpose(1, 2, 0)

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
        d_t = _buffer(work, "d_t", d.shape[::-1])
        np.copyto(d_t, d.T)
        sd, cd = _sin_cos_small(d_t, work)  # (n, T)
        st, ct = self.sin_theta, self.cos_theta  # (K, n, 1)
        shape = (*self.sin_theta.shape[:2], d.shape[0])
        tmp, a_i, a_o, u = (_buffer(work, name, shape) for name in ("tmp", "a_i", "a_o", "u"))
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


class HeadStudy:
    """One seed block of the study: ``study(rng, n) -> (n, p)`` (picklable).

    For each of ``n`` trials: draws the head errors, the noise of every
    reading and the first-harmonic measurement error (in that order, per
    sub-block of :data:`SUB_BLOCK` trials), simulates the outputs exactly
    and reduces them by every method with precomputed linear operators.

    Outputs (``names``): the actual error of every coefficient of every
    sensor by every method, then the per-trial factors of the formal SDs
    (see :meth:`summarise`).
    """

    def __init__(self, rig: DividingHeadRig, methods, h1_sd: float):
        self.rig = rig
        self.methods = tuple(methods)
        self.h1_sd = float(h1_sd)
        alpha, phi = rig.positions, rig.mounts
        self.k, self.n = k, n = phi.size, alpha.size
        beta = rig.sensor_angles()
        self.sensors = SensorBank(rig.models, beta + rig.eta[:, None])
        design = psi(beta)  # (K, n, 5)
        pinv, _res, cov = single_operator(beta)
        basis = residual_basis(design)  # (K, n, n - 5)
        m = self.single_dof = n - 5
        # Single-sensor stage, per sensor: estimates then residual coordinates.
        self.single_op = np.concatenate([pinv, np.swapaxes(basis, 1, 2)], axis=1)
        self.single_sd_unit = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))  # (K, 5)
        h1_cov = np.eye(2) * self.h1_sd**2
        self.sd_unit, self.sd_extra, self.h1_gain = {}, {}, {}
        self.families = tuple(f for f in ("four", "joint") if any(
            name.startswith(f) for name in self.methods))
        # Every other method acts on the normalised outputs U'_k = U_k / K_I,k. Their
        # parts in the single fits' model spaces pass through unchanged, so the methods
        # differ only in what they do with the residual coordinates r (K (n - 5) numbers):
        # both remove the effect of a head-error estimate, which lies in the range of
        # ``effect`` (d -> residual coordinates of d cos(beta_k)), orthonormal basis q.
        blk_design, blk_basis = _block_diagonal(design), _block_diagonal(basis)
        cos_beta = np.cos(beta)
        effect = (np.swapaxes(basis, 1, 2) * cos_beta[:, None, :]).reshape(k * m, n)
        x_of_d = (pinv * cos_beta[:, None, :]).reshape(5 * k, n)  # d -> estimates
        u_svd, sv, _ = np.linalg.svd(effect, full_matrices=False)
        q = u_svd[:, sv > 1e-9 * sv[0]]  # (K (n - 5), rank)
        stage, x_gain = [], []
        if "four" in self.families:
            four = FourOperator.build(alpha, phi)
            # Step 4 [DOMAIN]: V'_k = U'_k - d_hi cos(beta_k), then the single-sensor fit.
            # d_hi = four.angle @ U' depends on r only; y = q' (effect d_hi) carries it all.
            _require_close(four.angle @ blk_design, 0.0, "d_hi ignores the model spaces")
            angle_r = four.angle @ blk_basis  # (n, K (n - 5))
            y_of_r = q.T @ (effect @ angle_r)
            _require_close(q @ y_of_r, effect @ angle_r, "d_hi's effect lies in range(q)")
            gain = -x_of_d @ angle_r @ np.linalg.pinv(y_of_r)
            _require_close(gain @ y_of_r, -x_of_d @ angle_r, "estimates follow from y")
            stage.append(y_of_r)
            x_gain.append(gain)
            self.sd_unit["four"] = np.sqrt(np.diagonal(four.cov_unit, axis1=1, axis2=2))
            self.h1_gain["four"] = -four.alias
            self.sd_extra["four"] = np.einsum("kpi,ij,kpj->kp", four.alias, h1_cov, four.alias)
        if "joint" in self.families:
            joint = JointOperator.build(alpha, phi)
            # Joint least squares: estimates x' + G r with G r = G q q' r; residual
            # r - q q' r (the joint residual space is range(q)'s complement, joint.dof).
            x_joint = joint.pinv[:5 * k]
            _require_close(x_joint @ blk_design, np.eye(5 * k), "joint keeps the model spaces")
            g = x_joint @ blk_basis
            _require_close(g @ q @ q.T, g, "joint estimates follow from q' r")
            resid = blk_basis @ (np.eye(k * m) - q @ q.T) @ blk_basis.T
            _require_close(resid, joint.resid, "joint residual space")
            stage.append(q.T)
            x_gain.append(g @ q)
            self.dof_joint = joint.dof
            self.sd_unit["joint"] = np.sqrt(np.diag(joint.cov_unit)[:5 * k]).reshape(k, 5)
            gg = joint.gauge[:5 * k, 1:].reshape(k, 5, 2)
            self.h1_gain["joint"] = gg
            self.sd_extra["joint"] = np.einsum("kpi,ij,kpj->kp", gg, h1_cov, gg)
        self.q = q
        self.stage_op = np.concatenate(stage) if stage else np.zeros((0, k * m))
        self.x_gain = np.stack(x_gain) if x_gain else np.zeros((0, 5 * k, q.shape[1]))
        self.h1_gain_all = np.stack(
            [self.h1_gain[f].reshape(5 * k, 2) for f in self.families]
        ) if self.families else np.zeros((0, 5 * k, 2))
        c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], axis=-1)
        self.gauge_proj = np.linalg.pinv(c)  # (3, n): d0, d1c, d1s of d
        self.coef = np.array(
            [[mod.to_dong2014()[name] for name in COEFFICIENTS] for mod in rig.models]
        )
        self.names = self._names()
        # The single fit of the outputs at d = 0 (SensorBank.offset), in extended precision:
        # K_I and the estimates minus the truth. Its residual coordinates vanish exactly
        # (the study's models are Dong2014 eq. (5) models: their outputs lie in Psi's span).
        # Estimates refined against Psi in extended precision: a float64 operator's own
        # rounding (~1e-16 of the outputs) would otherwise bias every trial alike.
        op = self.single_op.astype(np.longdouble)
        offset = np.einsum("kij,kj->ki", op, self.sensors.offset)
        sb, cb = np.sin(beta.astype(np.longdouble)), np.cos(beta.astype(np.longdouble))
        design_ld = np.stack([np.ones_like(sb), sb, cb, sb * cb, sb * sb], axis=-1)
        for _ in range(2):
            fit_residual = self.sensors.offset - np.einsum("kji,ki->kj", design_ld, offset[:, :5])
            offset[:, :5] += np.einsum("kij,kj->ki", op[:, :5], fit_residual)
        self.k_i0 = offset[:, 1].astype(float)
        base0 = offset[:, :5] - self.coef
        base0[:, 2] -= self.coef[:, 1] * rig.eta  # K_O* = K_O + K_I (eta + d0) [DOMAIN 6]
        self.base0 = base0.astype(float)
        self.dof = {"single": m, "four": m, "joint": getattr(self, "dof_joint", 0)}
        self.any_known = any(name.endswith("_known_h1") for name in self.methods)
        # Per method: family, its slot in the residual stages, known h1, full SD, output rows.
        plan, width, sd_at = [], 5 * k, len(self.methods) * 5 * k
        for j, method in enumerate(self.methods):
            family = method.split("_", maxsplit=1)[0]
            full = self._full_sd(method)
            rows = width if full else k
            slot = 0 if family == "single" else 1 + self.families.index(family)
            plan.append((family, slot, method.endswith("_known_h1"), full,
                         slice(j * width, (j + 1) * width), slice(sd_at, sd_at + rows)))
            sd_at += rows
        self.plan = tuple(plan)
        self.single_rows = next((rows for family, *_, rows, _ in plan if family == "single"), None)

    # ------------------------------------------------------------------ layout
    def _full_sd(self, method: str) -> bool:
        """Whether a method's formal SD needs one output per coefficient (h1 term)."""
        family = method.split("_", maxsplit=1)[0]
        return method.endswith("known_h1") and not method.endswith("unknown_h1") and bool(
            np.any(self.sd_extra.get(family, 0.0))
        )

    def _names(self) -> tuple[str, ...]:
        sensors = [f"U{i + 1}" for i in range(self.k)]
        names = [f"error:{m}:{s}:{c}" for m in self.methods for s in sensors for c in COEFFICIENTS]
        for m in self.methods:
            if self._full_sd(m):
                names += [f"sd:{m}:{s}:{c}" for s in sensors for c in COEFFICIENTS]
            else:
                names += [f"sd_factor:{m}:{s}" for s in sensors]
        return tuple(names)

    def summarise(self, rms: np.ndarray, mean: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """RMS errors and mean formal SDs ``(methods, K, 5)`` from the outputs' RMS and mean.

        Where a formal SD is a per-trial factor times a constant (no
        first-harmonic term), the study keeps the factor and the mean SD is
        the constant times its mean.
        """
        m, k = len(self.methods), self.k
        rms_error = rms[: m * k * 5].reshape(m, k, 5)
        sds, at = [], m * k * 5
        for method in self.methods:
            if self._full_sd(method):
                sds.append(mean[at: at + 5 * k].reshape(k, 5))
                at += 5 * k
            else:
                sds.append(mean[at: at + k, None] * self._sd_unit(method))
                at += k
        return rms_error, np.stack(sds)

    def _sd_unit(self, method: str) -> np.ndarray:
        family = method.split("_", maxsplit=1)[0]
        return self.single_sd_unit if family == "single" else self.sd_unit[family]

    # ---------------------------------------------------------------- simulate
    def __call__(self, rng: np.random.Generator, trials: int) -> np.ndarray:
        """Errors and formal-SD factors of ``trials`` trials, shape ``(trials, p)``."""
        out = np.empty((len(self.names), trials))  # trials contiguous, returned transposed
        work: dict = {}  # buffers reused across sub-blocks: fresh pages cost more than flops
        for start in range(0, trials, SUB_BLOCK):
            t = min(SUB_BLOCK, trials - start)
            # Filled in a small buffer that stays in cache, then copied out in one pass.
            res_t = _buffer(work, "res_t", (len(self.names), t))
            self._sub_block(rng, res_t, work)
            out[:, start:start + t] = res_t
        return out.T

    def draw(self, rng: np.random.Generator, trials: int, work: dict | None = None):
        """Head errors ``(T, n)``, mean noise ``(T, K, n)`` and h1 errors ``(T, 2)``.

        The same numbers, in the same order, as ``rig.angle_errors``,
        ``rig.outputs`` and ``rng.standard_normal((T, 2))`` would draw.
        """
        rig, work = self.rig, {} if work is None else work
        d = rig.angle_errors(trials, rng)
        if (rig.noise > 0).any():
            shape = (trials, rig.repeats, self.k, self.n)
            noise = rng.standard_normal(out=_buffer(work, "noise", shape))
            if rig.repeats > 1:
                noise = noise.mean(axis=1, out=_buffer(work, "noise_mean", shape[::2] + shape[3:]))
            else:
                noise = noise[:, 0]
            noise *= rig.noise[:, None]
        else:
            noise = np.zeros((trials, self.k, self.n))
        return d, noise, rng.standard_normal((trials, 2))

    def _sub_block(self, rng, res_t, work):
        """Fill ``res_t`` ``(p, t)`` with the outputs of ``t`` trials (one per column)."""
        k, n, t = self.k, self.n, res_t.shape[1]
        m, families, f = self.single_dof, self.families, len(self.families)
        d, noise, h1_noise = self.draw(rng, t, work)
        u = self.sensors.variation(d, noise, work)  # (K, n, T): outputs - offset
        # Single-sensor stage, per sensor (also each scale factor, step 0 [DOMAIN]), on the
        # variation; the offset's share is added to the small results, not to the outputs.
        single = np.matmul(self.single_op, u, out=_buffer(work, "single", (k, n, t)))
        k_i = np.add(single[:, 1], self.k_i0[:, None], out=_buffer(work, "k_i", (k, t)))
        g = self.gauge_proj @ d.T  # (3, T): d0, d1c, d1s
        # Actual error of the single fit: x - truth, K_O* = K_O + K_I (eta + d0) [DOMAIN 6].
        base = _buffer(work, "base", (k, 5, t)) if self.single_rows is None else \
            res_t[self.single_rows].reshape(k, 5, t)
        np.add(single[:, :5], self.base0[..., None], out=base)
        base[:, 2] -= np.multiply(self.coef[:, 1, None], g[0], out=_buffer(work, "k_o", (k, t)))
        # Normalised residual coordinates r (slot 0) and, for four, r minus the effect
        # q y of its head-error estimate (slot 1).
        inv = np.divide(1.0, k_i, out=_buffer(work, "inv_k_i", (k, t)))
        four = int("four" in families)
        res = _buffer(work, "res", (1 + four, k * m, t))
        r = res[0]
        np.multiply(single[:, 5:], inv[:, None], out=r.reshape(k, m, t))
        if families:
            y = np.matmul(self.stage_op, r, out=_buffer(work, "y", (f * self.q.shape[1], t)))
            y = y.reshape(f, -1, t)
            if four:
                np.matmul(self.q, y[0], out=res[1])
                np.subtract(r, res[1], out=res[1])
            corr = np.matmul(self.x_gain, y, out=_buffer(work, "corr", (f, 5 * k, t)))
            if self.any_known:
                h1_given = g[1:] + self.h1_sd * h1_noise.T if self.h1_sd else g[1:]  # (2, T)
                corr_h1 = np.matmul(self.h1_gain_all, h1_given,
                                    out=_buffer(work, "corr_h1", (f, 5 * k, t)))
                corr_h1 += corr
        # Residual sums of squares (normalised): Eq. (30) [Dong2014] per sensor, pooled
        # over the sensors for joint.
        sq = np.einsum("fkrt,fkrt->fkt", *(res.reshape(1 + four, k, m, t),) * 2)
        rss = {"single": sq[0], "four": sq[-1]}
        if "joint" in families:
            rss["joint"] = self._joint_rss(r, y[-1], sq[0])
        abs_k_i = np.abs(k_i)
        done = {}
        for family, i, known, full, err_rows, sd_rows in self.plan:
            if family != "single":
                # Error (x' + c) K_I - truth = base + K_I c, c the method's correction
                # (plus the first harmonic's, step 5 [DOMAIN], when it is known).
                c = (corr_h1 if known else corr)[i - 1].reshape(k, 5, t)
                err = res_t[err_rows].reshape(k, 5, t)
                np.multiply(c, k_i[:, None], out=err)
                err += base
            if family in done and not full:
                res_t[sd_rows] = done[family]
                continue
            s2 = rss[family]  # times 1 / dof below
            if full:
                var = s2[:, None] * (self.sd_unit[family] ** 2 / self.dof[family])[..., None] \
                    + self.sd_extra[family][..., None]
                np.sqrt(var, out=var)
                np.multiply(var, abs_k_i[:, None], out=res_t[sd_rows].reshape(k, 5, t))
                continue
            factor = res_t[sd_rows]  # (K, T): SD / sd_unit (output units)
            np.multiply(s2, 1.0 / self.dof[family], out=factor)
            np.sqrt(factor, out=factor)
            factor *= abs_k_i
            done[family] = factor

    def _joint_rss(self, r: np.ndarray, y: np.ndarray, sq_r: np.ndarray) -> np.ndarray:
        """Pooled joint residual sum of squares ``|r - q y|^2``, shape ``(1, T)``.

        With ``q`` orthonormal and ``y = q' r`` it equals ``|r|^2 - |y|^2``: no
        product by ``q``. Where that difference would lose more than 10 bits
        (``|r|^2 > 1024 RSS``) the trials are recomputed from ``r - q y``.
        """
        total = sq_r.sum(axis=0)
        out = total - np.einsum("rt,rt->t", y, y)
        lossy = np.flatnonzero(out * 1024.0 < total)
        if lossy.size:
            e = r[:, lossy] - self.q @ y[:, lossy]
            out[lossy] = np.einsum("rt,rt->t", e, e)
        return out[None]


def _block_diagonal(blocks: np.ndarray) -> np.ndarray:
    """The block-diagonal matrix of ``blocks`` ``(K, a, b)``, shape ``(K a, K b)``."""
    k, a, b = blocks.shape
    out = np.zeros((k, a, k, b))
    out[np.arange(k), :, np.arange(k)] = blocks
    return out.reshape(k * a, k * b)


def _require_close(a, b, what: str) -> None:
    """Check an identity the factored operators rely on (exact up to rounding)."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    scale = max(1.0, float(np.max(np.abs(b), initial=0.0)))
    if not np.max(np.abs(a - b), initial=0.0) <= 1e-8 * scale:
        raise AccelcalError(f"study operators: {what} does not hold for this design")
