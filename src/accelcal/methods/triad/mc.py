"""Monte Carlo (GUM-S1) uncertainty of a triad calibration.

Synthetic sets of interval means are drawn from the fitted calibration:

- known orientations: the readings the fitted model predicts at the known
  specific forces ``g up_k``;
- gravity norm: the readings of the fitted model at ``g a_k / |a_k|``
  (``a_k`` the calibrated mean: its direction, with the exact local gravity),

plus Gaussian noise with the SD of each interval mean (observation
``means_sd``: given, or at the residual level) and, with a stated fixture
tilt, the readings of a fixture turned by a random small rotation at each
position (:mod:`accelcal.methods.triad.pairs`), and, when the reduction
bounds each axis's pendulous terms by priors
(:func:`accelcal.methods.triad.unestimated.with_type_b`), those terms drawn
from their priors and their change of the means added. Each set is re-reduced by
the same estimator as the measured means (per-axis pairs or linear least
squares and RQ split, or Levenberg-Marquardt from the fitted values); the
sampler returns
the errors ``x* - x``, which :func:`accelcal.uncertainty.propagate` turns
into standard uncertainties and coverage intervals. The re-reductions are
nonlinear, one per trial (about 0.1 ms for known orientations, a few ms for
the gravity norm).

Sampling error: the relative standard error of a Monte Carlo SD from ``M``
trials is ``1 / sqrt(2 (M - 1))`` (Gaussian output): 2.2 % at 1000 trials.

References
----------
.. [GUM-S1] JCGM 101:2008, sections 5-7.
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.triad.forward import known_model
from accelcal.methods.triad.model import TriadCalibration
from accelcal.uncertainty import McUncertainty, propagate


@dataclass(frozen=True)
class TriadSampler:
    """Picklable sampler of re-reduced synthetic interval means.

    Parameters
    ----------
    route : {"known", "unknown"}
    clean : numpy.ndarray, shape (n, 3)
        Noise-free means of the fitted calibration.
    sd : numpy.ndarray, shape (n, 3)
        SD of each interval mean.
    values : numpy.ndarray
        The fitted parameters (9 or 12; 12 or 15 with the gauge for known).
    weights : numpy.ndarray
        Relative SDs the estimator weights with: ``(n, 3)`` known, ``(n,)`` unknown.
    force : numpy.ndarray or None
        ``g up_k`` (known orientations).
    gravity : float
    quadratic : bool
    p : int
        Parameters reported (9 or 12).
    given : bool
        The noise SD was given (the gravity-norm estimator then reweights with it).
    estimator : str
        The known-orientation estimator (``pairs`` or ``least-squares``).
    up : numpy.ndarray or None
        The positions' up vectors (known orientations).
    tilt : numpy.ndarray or None
        ``(n, 3, 3)`` maps of a standard normal 3-vector to each position's
        reading error from the fixture tilt (None: no tilt stated).
    tilt_sd : float or None
        The stated fixture tilt, rad (the gls estimator weighs with it).
    priors : tuple of Prior
        Priors of the axes' pendulous terms, drawn in every trial.
    prior_columns : numpy.ndarray or None
        Their change of the means per unit term, ``(len(priors), n, 3)``.

    Calling ``sampler(rng, t)`` returns the errors ``(t, p)``.
    """

    route: str
    clean: np.ndarray
    sd: np.ndarray
    values: np.ndarray
    weights: np.ndarray
    force: np.ndarray | None
    gravity: float
    quadratic: bool
    p: int
    given: bool = False
    estimator: str = "least-squares"
    up: np.ndarray | None = None
    tilt: np.ndarray | None = None
    tilt_sd: float | None = None
    priors: tuple = ()
    prior_columns: np.ndarray | None = None

    def __call__(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Errors of ``t`` re-reduced synthetic sets, shape ``(t, p)``."""
        from accelcal.methods.triad.known import estimate_known
        from accelcal.methods.triad.unknown import estimate_unknown

        noise = rng.standard_normal((t, *self.clean.shape)) * self.sd
        if self.tilt is not None:
            z = rng.standard_normal((t, *self.clean.shape))
            noise = noise + np.einsum("kij,tkj->tki", self.tilt, z)
        if self.priors:
            draws = np.stack([p.draw(rng, t) for p in self.priors], axis=1)
            noise = noise + np.einsum("tp,pki->tki", draws, self.prior_columns)
        out = np.empty((t, self.p))
        for r in range(t):
            u = self.clean + noise[r]
            if self.route == "known":
                x = estimate_known(u, self.force, self.weights, self.quadratic, self.up,
                                   estimator=self.estimator, tilt=self.tilt_sd)[1]
            else:
                x = estimate_unknown(u, self.gravity, self.quadratic, self.weights,
                                     self.sd if self.given else None, x0=self.values)[0]
            out[r] = x[:self.p] - self.values[:self.p]
        return out


def sampler_of(reduction) -> TriadSampler:
    """The :class:`TriadSampler` of a triad reduction (from its fields only)."""
    from accelcal.methods.triad.common import relative_sd

    if reduction.family != "triad":
        raise AccelcalError(f"not a triad reduction (family {reduction.family!r})",
                            parameter="reduction")
    obs, prov = reduction.observations, reduction.provenance
    est = reduction.estimate
    quadratic = bool(prov["quadratic"])
    means, sd = obs["means"], obs["means_sd"]
    n = means.shape[0]
    counts = prov.get("counts")
    given = reduction.assumed("noise") == "given"
    rel = relative_sd(n, counts)
    if "up" in obs:
        rot0 = obs["rotation"].T  # fixture-to-body
        values = np.concatenate([est.values, np.zeros(3)])
        force = prov["gravity"] * obs["up"]
        clean = known_model(values, rot0, force, quadratic)[0]
        weights = sd if given else np.repeat(rel[:, None], 3, axis=1)
        tilt = None
        if prov.get("fixture_tilt"):
            from accelcal.methods.triad.pairs import tilt_blocks

            pred = known_model(values, rot0, np.vstack([np.zeros(3), np.eye(3)]), False)[0]
            tilt = tilt_blocks((pred[1:] - pred[0]).T, obs["up"], prov["gravity"],
                               prov["fixture_tilt"])
        return TriadSampler("known", clean, sd, values, weights, force, prov["gravity"],
                            quadratic, est.values.size, estimator=prov.get(
                                "estimator", "least-squares"), up=obs["up"], tilt=tilt,
                            tilt_sd=prov.get("fixture_tilt"),
                            **_prior_fields(reduction, means, obs["up"]))
    cal = TriadCalibration.from_vector(est.values, prov["input_unit"])
    a = cal.apply(means)
    clean = cal.readings(prov["gravity"] * a / np.linalg.norm(a, axis=1)[:, None])
    return TriadSampler("unknown", clean, sd, est.values.copy(), rel, None, prov["gravity"],
                        quadratic, est.values.size, given,
                        **_prior_fields(reduction, means, None))


def _prior_fields(reduction, means, up) -> dict:
    """``priors`` and ``prior_columns`` of the axes' pendulous terms the reduction bounds."""
    if not reduction.priors:
        return {}
    from accelcal.methods.triad.unestimated import term_columns

    prov = reduction.provenance
    names, columns, _ = term_columns(reduction, means, gravity=prov["gravity"], up=up,
                                     labels=prov.get("labels"), bound=False)
    by_name = {p.name: p for p in reduction.priors}
    chosen = [(by_name[full], col) for (full, _), col in zip(names, columns, strict=True)
              if full in by_name]
    if not chosen:
        return {}
    return {"priors": tuple(p for p, _ in chosen),
            "prior_columns": np.array([c for _, c in chosen])}


def triad_uncertainty(reduction, *, trials: int, seed: int, shortest: bool = False,
                      progress=None, workers=None, scheduler=None,
                      force: bool = False) -> McUncertainty:
    """Monte Carlo uncertainty of a triad calibration (either route).

    Parameters
    ----------
    reduction : Reduction
        From :func:`~accelcal.methods.triad.calibrate_known` or
        :func:`~accelcal.methods.triad.calibrate_unknown`.
    trials, seed : int
        Monte Carlo trials (> 0) and root seed.
    shortest : bool
        Shortest coverage interval instead of the symmetric one.
    progress, workers, scheduler, force
        Passed to :func:`accelcal.uncertainty.propagate`.

    Returns
    -------
    McUncertainty
        One entry per calibration parameter.

    References
    ----------
    .. [1] JCGM 101:2008 (GUM-S1), 7.2-7.7.
    """
    sampler = sampler_of(reduction)
    est = reduction.estimate
    given = reduction.assumed("noise") == "given"
    inputs = [("interval-mean noise N(0, u_k) as given" if given else
               "interval-mean noise N(0, u_k) at the residual level")
              + f" ({reduction.provenance['input_unit']})"]
    if reduction.provenance.get("fixture_tilt"):
        inputs.append(f"fixture tilt N(0, {reduction.provenance['fixture_tilt']:.3g} rad) about "
                      "each horizontal axis at each position (Type B)")
    if sampler.priors:
        inputs.append("each axis's pendulous terms drawn from their priors: " + ", ".join(
            dict.fromkeys(f"{p.name.split('[')[0].split('@')[0]} {p.distribution} "
                          f"{p.value:.3g} {p.unit}" for p in sampler.priors)))
    return propagate(sampler, est.values, est.std, names=est.names, trials=trials, seed=seed,
                     units=dict(est.units), shortest=shortest, inputs=inputs, progress=progress,
                     workers=workers, scheduler=scheduler, force=force)
