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

Vectorised: every reduction is a fixed linear operator (after each
sensor's normalisation by its own fitted scale factor), applied to a block
of trials by matrix products; there is no per-trial Python loop. Trials
are drawn in blocks of :data:`RNG_BLOCK`, block b from child b of one
``numpy.random.SeedSequence``, so results do not depend on ``chunk``.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, section 3, Tables 1-2.
.. [DOMAIN] accelcal domain notes, section 4 (checks: formal SDs against
   Monte Carlo RMS errors).
"""

import itertools
from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.dividing_head import (
    COEFFICIENTS,
    FourOperator,
    JointOperator,
    single_operator,
)
from accelcal.rigs.dividing_head import DividingHeadRig

STUDY_METHODS = ("single", "four_unknown_h1", "four_known_h1", "joint_unknown_h1",
                 "joint_known_h1")

RNG_BLOCK = 256
"""Trials drawn from one child seed; chunks are whole numbers of blocks."""


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
    chunk: int = 8192,
    methods=None,
) -> StudyResult:
    """Run the Monte Carlo study.

    Parameters
    ----------
    rig : DividingHeadRig
        Truth, positions, mounts, head error profile, first harmonic, noise.
        ``four`` methods need uniform positions (n >= 12) and balanced mounts.
    trials : int
        Number of trials.
    seed : int or numpy.random.SeedSequence
        Root seed.
    h1_sd : float
        Standard deviation of the first-harmonic measurement given to the
        ``known_h1`` methods, rad (their covariance includes it).
    chunk : int
        Trials processed at once (rounded up to whole RNG blocks); bounds
        memory, does not change the result.
    methods : sequence of str, optional
        Subset of :data:`STUDY_METHODS`; by default every method the rig
        allows (``four`` needs uniform positions and balanced mounts,
        ``joint`` an identifiable design).

    Returns
    -------
    StudyResult

    References
    ----------
    .. [1] [DOMAIN] section 4: formal SDs against Monte Carlo RMS errors.
    """
    trials = int(trials)
    if trials < 2:
        raise AccelcalError(f"a study needs at least 2 trials, got {trials}")
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
    ops = _Operators(rig, methods)
    blocks_per_chunk = max(1, -(-int(chunk) // RNG_BLOCK))
    n_blocks = -(-trials // RNG_BLOCK)
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    children = root.spawn(n_blocks)
    k = rig.n_sensors
    sq_parts, sd_parts = [], []
    for start in range(0, n_blocks, blocks_per_chunk):
        block_ids = range(start, min(start + blocks_per_chunk, n_blocks))
        sizes = [min(RNG_BLOCK, trials - b * RNG_BLOCK) for b in block_ids]
        d, u, h1_err = _draw(rig, [children[b] for b in block_ids], sizes)
        err, sd = ops.apply(d, u, h1_err, h1_sd)  # (M, T, K, 5) each
        edges = np.cumsum([0, *sizes])
        for a, b in itertools.pairwise(edges):
            sq_parts.append((err[:, a:b] ** 2).sum(axis=1))
            sd_parts.append(sd[:, a:b].sum(axis=1))
    sq = np.zeros((len(methods), k, 5))
    sd_sum = np.zeros((len(methods), k, 5))
    for a, b in zip(sq_parts, sd_parts, strict=True):
        sq = sq + a
        sd_sum = sd_sum + b
    unit = rig.models[0].output_unit
    return StudyResult(methods, np.sqrt(sq / trials), sd_sum / trials, trials, unit, notes)


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


def _draw(rig, seeds, sizes):
    """Angle errors, outputs and h1 measurement errors for blocks of trials."""
    ds, us, hs = [], [], []
    for ss, size in zip(seeds, sizes, strict=True):
        rng = np.random.default_rng(ss)
        d = rig.angle_errors(size, rng)
        ds.append(d)
        us.append(rig.outputs(d, rng).mean(axis=1))  # average repeats
        hs.append(rng.standard_normal((size, 2)))
    return np.concatenate(ds), np.concatenate(us), np.concatenate(hs)


class _Operators:
    """Precomputed linear operators and truth for one rig."""

    def __init__(self, rig: DividingHeadRig, methods):
        self.methods = methods
        alpha, phi = rig.positions, rig.mounts
        self.k, self.n = phi.size, alpha.size
        beta = rig.sensor_angles()
        self.single_pinv, self.single_res, self.single_cov = single_operator(beta)
        if any(m.startswith("four") for m in methods):
            self.four = FourOperator.build(alpha, phi)
        if any(m.startswith("joint") for m in methods):
            self.joint = JointOperator.build(alpha, phi)
            self.joint_sd_unit = np.sqrt(np.diag(self.joint.cov_unit)[:5 * self.k]).reshape(
                self.k, 5)
            g = self.joint.gauge[:5 * self.k, 1:].reshape(self.k, 5, 2)
            self.joint_h1 = g
        c = np.stack([np.ones_like(alpha), np.cos(alpha), np.sin(alpha)], axis=-1)
        self.gauge_proj = np.linalg.pinv(c)  # (3, n): d0, d1c, d1s of d
        coef = np.array([[m.to_dong2014()[name] for name in COEFFICIENTS] for m in rig.models])
        self.coef = coef
        self.eta = rig.eta
        self.dof_single = self.n - 5

    def apply(self, d, u, h1_noise, h1_sd):
        """Errors and formal SDs, each ``(methods, T, K, 5)``, in the output unit."""
        t = d.shape[0]
        g = d @ self.gauge_proj.T  # (T, 3)
        truth = np.broadcast_to(self.coef, (t, self.k, 5)).copy()
        truth[..., 2] += self.coef[:, 1] * (self.eta + g[:, 0:1])  # K_O* [DOMAIN step 6]
        k_i = np.einsum("kn,tkn->tk", self.single_pinv[:, 1, :], u)  # step 0 [DOMAIN]
        un = (u / k_i[..., None]).reshape(t, -1)
        h1_given = g[:, 1:] + h1_sd * h1_noise
        h1_cov = np.eye(2) * h1_sd**2
        errs, sds = [], []
        for name in self.methods:
            if name == "single":
                est = np.einsum("kpn,tkn->tkp", self.single_pinv, u)
                res = np.einsum("kmn,tkn->tkm", self.single_res, u)
                s2 = (res**2).sum(-1) / self.dof_single
                var = s2[..., None] * np.diagonal(self.single_cov, axis1=-2, axis2=-1)
            elif name.startswith("four"):
                op = self.four
                x = np.einsum("kpm,tm->tkp", op.coef, un)
                res = np.einsum("knm,tm->tkn", op.resid, un)
                s2 = (res**2).sum(-1) / self.dof_single
                var = s2[..., None] * np.diagonal(op.cov_unit, axis1=-2, axis2=-1)
                if name == "four_known_h1":
                    x = x - np.einsum("kpi,ti->tkp", op.alias, h1_given)
                    var = var + np.einsum("kpi,ij,kpj->kp", op.alias, h1_cov, op.alias)
                est, var = x * k_i[..., None], var * k_i[..., None] ** 2
            else:
                op = self.joint
                sol = un @ op.pinv.T  # (T, p)
                x = sol[:, :5 * self.k].reshape(t, self.k, 5)
                res = un @ op.resid.T
                s2 = (res**2).sum(-1) / op.dof
                var = s2[:, None, None] * self.joint_sd_unit**2
                if name == "joint_known_h1":
                    x = x + np.einsum("kpi,ti->tkp", self.joint_h1, h1_given)
                    var = var + np.einsum("kpi,ij,kpj->kp", self.joint_h1, h1_cov, self.joint_h1)
                est, var = x * k_i[..., None], var * k_i[..., None] ** 2
            errs.append(est - truth)
            sds.append(np.sqrt(np.broadcast_to(var, (t, self.k, 5))))
        return np.stack(errs), np.stack(sds)
