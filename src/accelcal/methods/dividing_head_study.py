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
trials on the contiguous axis; residual sums of squares come from
orthonormal bases of the residual spaces (``n - 5`` numbers per sensor, the
joint design's ``dof``). There is no per-trial Python loop.

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
        self.sin_theta, self.cos_theta = np.sin(theta)[..., None], np.cos(theta)[..., None]
        terms = {name: np.array([getattr(mod, name) for mod in models])[:, None, None]
                 for name in ("K0", "K1", "K2", "K3", "K4", "Ko", "Koo", "Kio",
                              "K0_asym", "K1_asym")}
        for group in (("K3", "K4"), ("Koo",), ("K0_asym", "K1_asym")):
            if not any(np.any(terms[name]) for name in group):
                for name in group:
                    del terms[name]
        self.model_terms = terms

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
        pinv, _res, cov = single_operator(beta)
        basis = residual_basis(psi(beta))  # (K, n, n - 5)
        # Single-sensor stage, per sensor: estimates then residual coordinates.
        self.single_op = np.concatenate([pinv, np.swapaxes(basis, 1, 2)], axis=1)
        self.single_dof = n - 5
        self.single_sd_unit = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))  # (K, 5)
        h1_cov = np.eye(2) * self.h1_sd**2
        blocks, self.slices, self.sd_unit, self.sd_extra, self.h1_gain = [], {}, {}, {}, {}
        start = 0

        def add(key, op):
            nonlocal start
            blocks.append(op)
            self.slices[key] = slice(start, start + op.shape[0])
            start += op.shape[0]

        if any(m.startswith("four") for m in self.methods):
            four = FourOperator.build(alpha, phi)
            # Step 4 [DOMAIN]: V'_k = U'_k - d_hi cos(beta_k), then the single-sensor fit
            # (FourOperator.coef and .resid factored: only d_hi acts on every sensor).
            add("four_dhi", four.angle)
            self.cos_beta = np.cos(beta)[..., None]
            self.sd_unit["four"] = np.sqrt(np.diagonal(four.cov_unit, axis1=1, axis2=2))
            self.h1_gain["four"] = -four.alias
            self.sd_extra["four"] = np.einsum("kpi,ij,kpj->kp", four.alias, h1_cov, four.alias)
        if any(m.startswith("joint") for m in self.methods):
            joint = JointOperator.build(alpha, phi)
            add("joint_x", joint.pinv[:5 * k])
            # Orthonormal basis of the residual projector's range (eigenvalues 1).
            w, v = np.linalg.eigh(joint.resid)
            add("joint_res", v[:, w > 0.5].T)
            self.dof_joint = joint.dof
            self.sd_unit["joint"] = np.sqrt(np.diag(joint.cov_unit)[:5 * k]).reshape(k, 5)
            g = joint.gauge[:5 * k, 1:].reshape(k, 5, 2)
            self.h1_gain["joint"] = g
            self.sd_extra["joint"] = np.einsum("kpi,ij,kpj->kp", g, h1_cov, g)
        self.dense_op = np.concatenate(blocks) if blocks else np.zeros((0, k * n))
        c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], axis=-1)
        self.gauge_proj = np.linalg.pinv(c)  # (3, n): d0, d1c, d1s of d
        self.coef = np.array(
            [[mod.to_dong2014()[name] for name in COEFFICIENTS] for mod in rig.models]
        )
        self.names = self._names()

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
            self._sub_block(rng, out[:, start:start + SUB_BLOCK], work)
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
        d, noise, h1_noise = self.draw(rng, t, work)
        u = self.sensors(d, noise, work)  # (K, n, T)
        # Single-sensor stage, per sensor (also each scale factor, step 0 [DOMAIN]).
        single = np.matmul(self.single_op, u, out=_buffer(work, "single", (k, n, t)))
        k_i = single[:, 1]  # (K, T)
        # Normalised outputs, sensor-major, through every other method's operator.
        u /= k_i[:, None]
        dense = np.matmul(self.dense_op, u.reshape(k * n, t),
                          out=_buffer(work, "dense", (self.dense_op.shape[0], t)))
        stage = {"single": (single[:, :5], single[:, 5:])}
        if "four_dhi" in self.slices:
            v = np.multiply(self.cos_beta, dense[self.slices["four_dhi"]],
                            out=_buffer(work, "four_v", u.shape))
            np.subtract(u, v, out=v)  # Eq. (22) corrected [DOMAIN]
            four = np.matmul(self.single_op, v, out=_buffer(work, "four", single.shape))
            stage["four"] = (four[:, :5], four[:, 5:])  # Eqs. (24), (29) [Dong2014]
        if "joint_x" in self.slices:
            stage["joint"] = (dense[self.slices["joint_x"]].reshape(k, 5, t),
                              dense[self.slices["joint_res"]])
        s2 = {}
        g = self.gauge_proj @ d.T  # (3, T): d0, d1c, d1s
        truth = np.empty((k, 5, t))
        truth[:] = self.coef[..., None]
        truth[:, 2] += self.coef[:, 1, None] * (self.rig.eta[:, None] + g[0])  # K_O* [DOMAIN 6]
        h1_given = g[1:] + self.h1_sd * h1_noise.T  # (2, T)
        abs_k_i = np.abs(k_i)
        width = 5 * k
        sd_at = len(self.methods) * width
        for m, method in enumerate(self.methods):
            family = method.split("_")[0]
            err = res_t[m * width:(m + 1) * width].reshape(k, 5, t)
            x, res = stage[family]
            if family not in s2:
                # Residual sums of squares: Eq. (30) [Dong2014] (per sensor) or pooled (joint).
                sq = np.einsum("rt,rt->t", res, res)[None] if family == "joint" else \
                    np.einsum("krt,krt->kt", res, res)
                s2[family] = sq / (self.dof_joint if family == "joint" else self.single_dof)
            if family == "single":
                np.subtract(x, truth, out=err)
            else:
                if method.endswith("_known_h1"):
                    x = x + self.h1_gain[family] @ h1_given  # Step 5 [DOMAIN]
                np.multiply(x, k_i[:, None], out=err)
                err -= truth
            if self._full_sd(method):
                var = s2[family][:, None] * self.sd_unit[family][..., None] ** 2 \
                    + self.sd_extra[family][..., None]
                np.multiply(np.sqrt(var), abs_k_i[:, None],
                            out=res_t[sd_at:sd_at + width].reshape(k, 5, t))
                sd_at += width
            else:
                factor = np.sqrt(s2[family])
                if family != "single":
                    factor = factor * abs_k_i
                res_t[sd_at:sd_at + k] = factor
                sd_at += k
