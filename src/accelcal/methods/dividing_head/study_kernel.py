"""One seed block of the indexing-head Monte Carlo study (:class:`HeadStudy`).

Vectorised: the designs are fixed, so every reduction is a precomputed
linear operator (after each sensor's normalisation by its own fitted scale
factor) applied to :data:`CHUNK` trials at once by matrix products,
trials on the contiguous axis; the random numbers are drawn :data:`SUB_BLOCK`
trials at a time, and each chunk's outputs are handed to the engine as one
piece (:meth:`HeadStudy.pieces`) while in cache. The single fit gives each sensor's
estimates and orthonormal residual coordinates; ``four`` and ``joint``
differ from it only by removing a head-error estimate whose effect lies in
one small subspace of those coordinates.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (30).
.. [DOMAIN] accelcal domain notes, section 4 (steps 0-7, joint least squares).
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head.factors import FourFactors
from accelcal.methods.dividing_head.four import FourOperator
from accelcal.methods.dividing_head.joint import JointOperator
from accelcal.methods.dividing_head.single import single_operator
from accelcal.methods.dividing_head.study_bank import SensorBank, scratch
from accelcal.methods.dividing_head.theory import COEFFICIENTS, psi
from accelcal.resources import check_memory
from accelcal.rigs.dividing_head import DividingHeadRig

SUB_BLOCK = 512
"""Trials drawn at once inside a seed block (part of the identity: the uniform head
errors, the noise and the first-harmonic errors of a sub-block are drawn in turn)."""

CHUNK = 2 * SUB_BLOCK
"""Trials reduced at once (whole sub-blocks; not part of the identity): long enough
that numpy's per-call overhead is small, short enough that the buffers stay in cache."""


def residual_basis(design: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``Q`` of the residual space of ``design`` ``(..., m, p)``.

    ``I - A A^+ = Q Q'``, so the residual sum of squares of data ``y`` is
    ``|Q' y|^2``: ``m - p`` numbers per record instead of ``m``.
    """
    p = design.shape[-1]
    q, _ = np.linalg.qr(design, mode="complete")
    return q[..., p:]


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
        # the designs are fixed: operators over all readings ((K n)^2), built once
        check_memory(k * n, k * n, 6, f"a study of {n} positions x {k} sensors",
                     parameter="positions")
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
            factors = FourFactors.build(alpha, phi)
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
            # Four's formal SD is the propagated one: per trial sqrt(M s2), with s2 each
            # sensor's noise variance solved without bias from its residual sum of squares
            # (residual_noise_variances) and M the coefficients' variance per unit variance.
            self.four_moments = factors.coefficient_moments()  # (5 K, K)
            res_moments = factors.residual_moments()
            self.four_unbias = np.linalg.inv(res_moments)  # (K, K)
            self.four_pool = 1.0 / res_moments.sum()
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
        self.any_noise = bool((rig.noise > 0).any())
        self.four_extra = bool(np.any(self.sd_extra.get("four", 0.0)))
        c1, s1 = rig.first_harmonic
        self.h1_wave = (c1 * np.cos(alpha), s1 * np.sin(alpha))
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
        """Whether a method's formal SD needs one output per coefficient.

        Four's propagated SD always does; the others' when an h1 term is added.
        """
        family = method.split("_", maxsplit=1)[0]
        return family == "four" or (
            method.endswith("known_h1") and not method.endswith("unknown_h1")
            and bool(np.any(self.sd_extra.get(family, 0.0))))

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
        """Errors and formal-SD factors of ``trials`` trials, shape ``(trials, p)``.

        The pieces of :meth:`pieces` gathered in one array (for tests and
        small studies; the engine streams the pieces instead).
        """
        out = np.empty((trials, len(self.names)))
        start = 0
        for piece in self.pieces(rng, trials):
            out[start:start + len(piece)] = piece
            start += len(piece)
        return out

    def pieces(self, rng: np.random.Generator, trials: int):
        """Yield the outputs of ``trials`` trials in order, :data:`CHUNK` trials at a time.

        Each piece ``(t, p)`` is a view of a buffer reused for the next
        piece: consume it (the engine takes its moments while it is in
        cache) before asking for the next. The random numbers are drawn
        sub-block by sub-block (:data:`SUB_BLOCK`) as :meth:`draw` would,
        whatever :data:`CHUNK`.
        """
        work: dict = {}  # buffers reused across chunks: fresh pages cost more than flops
        for start in range(0, trials, CHUNK):
            t = min(CHUNK, trials - start)
            d, noise, h1_noise = self._draw_chunk(rng, t, work)
            res_t = scratch(work, "res_t", (len(self.names), t))  # trials contiguous
            self._reduce(d, noise, h1_noise, res_t, work)
            yield res_t.T

    def draw(self, rng: np.random.Generator, trials: int, work: dict | None = None):
        """Head errors ``(T, n)``, mean noise ``(T, K, n)`` and h1 errors ``(T, 2)``.

        The same numbers, in the same order, as ``rig.angle_errors``,
        ``rig.outputs`` and ``rng.standard_normal((T, 2))`` would draw (one
        sub-block).
        """
        work = {} if work is None else work
        d, noise, h1 = self._buffers(trials, work)
        self._draw_into(rng, d, noise, h1)
        return self._finish_draw(d), self._noise_mean(noise, work), h1

    def _buffers(self, trials: int, work: dict):
        rig = self.rig
        return (scratch(work, "d", (trials, self.n)),
                scratch(work, "noise", (trials, rig.repeats, self.k, self.n)),
                scratch(work, "h1_noise", (trials, 2)))

    def _draw_chunk(self, rng, trials: int, work: dict):
        """:meth:`draw` of ``trials`` trials, one sub-block of draws after another."""
        d, noise, h1 = self._buffers(trials, work)
        for start in range(0, trials, SUB_BLOCK):
            stop = min(start + SUB_BLOCK, trials)
            self._draw_into(rng, d[start:stop], noise[start:stop], h1[start:stop])
        return self._finish_draw(d), self._noise_mean(noise, work, scale=False), h1

    def _draw_into(self, rng, d, noise, h1) -> None:
        """One sub-block's draws, in the rig's order, into the given (contiguous) arrays.

        ``rng.random`` scaled in place is ``rng.uniform`` bit for bit
        (``low + (high - low) * u``); the first harmonic and the noise level
        are applied by :meth:`_finish_draw` and :meth:`_noise_mean`.
        """
        profile = self.rig.angle_error
        if profile.kind == "uniform" and profile.half_width > 0:
            h = profile.half_width
            rng.random(out=d)
            d *= h - (-h)
            d += -h
        else:
            d[...] = profile.draw(self.rig.positions, len(d), rng)
        if self.any_noise:
            rng.standard_normal(out=noise)
        rng.standard_normal(out=h1)

    def _finish_draw(self, d):
        """Add the first harmonic to the drawn profile, as ``rig.angle_errors`` does."""
        d += self.h1_wave[0]  # (d + c cos) + s sin, the rig's order of operations
        d += self.h1_wave[1]
        return d

    def _noise_mean(self, noise, work, scale: bool = True):
        """Mean over the repeats of the standard normals, times each sensor's noise SD.

        Unscaled with ``scale=False`` (the reduction scales the noise as it
        transposes it).
        """
        if not self.any_noise:
            return np.zeros((noise.shape[0], self.k, self.n))
        if noise.shape[1] > 1:
            shape = noise.shape[::2] + noise.shape[3:]
            noise = noise.mean(axis=1, out=scratch(work, "noise_mean", shape))
        else:
            noise = noise[:, 0]
        if scale:
            noise *= self.rig.noise[:, None]
        return noise

    def _reduce(self, d, noise, h1_noise, res_t, work):
        """Fill ``res_t`` ``(p, t)`` with the outputs of ``t`` trials (one per column)."""
        k, n, t = self.k, self.n, res_t.shape[1]
        m, families, f = self.single_dof, self.families, len(self.families)
        scale = self.rig.noise if self.any_noise else None
        u = self.sensors.variation(d, noise, work, scale)  # (K, n, T): outputs - offset
        # Single-sensor stage, per sensor (also each scale factor, step 0 [DOMAIN]), on the
        # variation; the offset's share is added to the small results, not to the outputs.
        single = np.matmul(self.single_op, u, out=scratch(work, "single", (k, n, t)))
        k_i = np.add(single[:, 1], self.k_i0[:, None], out=scratch(work, "k_i", (k, t)))
        g = self.gauge_proj @ d.T  # (3, T): d0, d1c, d1s
        # Actual error of the single fit: x - truth, K_O* = K_O + K_I (eta + d0) [DOMAIN 6].
        base = scratch(work, "base", (k, 5, t)) if self.single_rows is None else \
            res_t[self.single_rows].reshape(k, 5, t)
        np.add(single[:, :5], self.base0[..., None], out=base)
        base[:, 2] -= np.multiply(self.coef[:, 1, None], g[0], out=scratch(work, "k_o", (k, t)))
        # Normalised residual coordinates r (slot 0) and, for four, r minus the effect
        # q y of its head-error estimate (slot 1).
        inv = np.divide(1.0, k_i, out=scratch(work, "inv_k_i", (k, t)))
        four = int("four" in families)
        res = scratch(work, "res", (1 + four, k * m, t))
        r = res[0]
        np.multiply(single[:, 5:], inv[:, None], out=r.reshape(k, m, t))
        if families:
            y = np.matmul(self.stage_op, r, out=scratch(work, "y", (f * self.q.shape[1], t)))
            y = y.reshape(f, -1, t)
            if four:
                np.matmul(self.q, y[0], out=res[1])
                np.subtract(r, res[1], out=res[1])
            corr = np.matmul(self.x_gain, y, out=scratch(work, "corr", (f, 5 * k, t)))
            if self.any_known:
                h1_given = g[1:] + self.h1_sd * h1_noise.T if self.h1_sd else g[1:]  # (2, T)
                corr_h1 = np.matmul(self.h1_gain_all, h1_given,
                                    out=scratch(work, "corr_h1", (f, 5 * k, t)))
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
            if family == "four":
                self._four_sd(rss["four"], known, abs_k_i, out=res_t[sd_rows].reshape(k, 5, t),
                              work=work, done=done)
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

    def _four_sd(self, rss, known, abs_k_i, *, out, work, done) -> None:
        """Four's propagated formal SDs ``(K, 5, T)`` into ``out`` from its residual sums.

        ``s2 = M_res^-1 rss`` (each sensor's unbiased noise variance; pooled
        for a trial where one is negative), then ``var = M s2`` (+ the h1 term
        when known), ``SD = sqrt(var) |K_I|``. ``var`` is computed once per
        sub-block for both four methods.
        """
        k, t = rss.shape
        if "four_var" not in done:  # once per sub-block (``done``) for both four methods
            s2 = np.matmul(self.four_unbias, rss, out=scratch(work, "four_s2", (k, t)))
            bad = s2.min(axis=0) < 0
            if bad.any():
                s2[:, bad] = rss[:, bad].sum(axis=0) * self.four_pool
            done["four_var"] = np.matmul(self.four_moments, s2,
                                         out=scratch(work, "four_var", (5 * k, t)))
        sd = out.reshape(5 * k, t)
        extra = known and self.four_extra
        if not extra and "four_sd" in done:  # the same SDs as the other four method's
            np.copyto(sd, done["four_sd"])
            return
        if extra:
            np.add(done["four_var"], self.sd_extra["four"].reshape(5 * k, 1), out=sd)
            np.sqrt(sd, out=sd)
        else:
            np.sqrt(done["four_var"], out=sd)
        out *= abs_k_i[:, None]
        if not extra:
            done["four_sd"] = sd

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
