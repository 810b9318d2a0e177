"""Monte Carlo (GUM-S1) uncertainty of VRE coefficients identified from measured VRE.

Synthetic VRE sets are drawn from the fitted coefficients (and the fixed
ones) over the measured (b, A) design, with

- each point's **VRE uncertainty** (Gaussian, independent; or, when the
  points carry none, the residual standard deviation of the fit);
- the **amplitude calibration** (Type B): every amplitude scaled by a common
  ``1 + e_A``, ``e_A ~ N(0, u_A)`` (one reference accelerometer measures all
  points);
- the **overload calibration** (Type B): every overload vector scaled by a
  common ``1 + e_b``, ``e_b ~ N(0, u_b)`` (the centrifuge's radius and speed);
- the **terms the fit leaves out** that the identification bounded by
  priors (``Reduction.priors``, :mod:`accelcal.methods.vre.unestimated`):
  each drawn from its prior as declared (rectangular, normal, two-point)
  and its VRE column added, so that the interval includes them as the
  formal Type B does.

Each set is reduced by the same linear operator as the measured VRE
(:func:`accelcal.methods.vre.identify`: weighted least squares, restricted
to the row space of the design when it is rank deficient), vectorised over
trials with the closed-form columns :func:`accelcal.methods.vre.vre_columns`.
The measured points come from the identification's observations.

References
----------
.. [Guan2021] Guan W., Asymmetry coefficient errors of accelerometer under
   overload-vibration environment, 2021, eqs. (9), (21), (24).
.. [GUM-S1] JCGM 101:2008, sections 5-7.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import analyse
from accelcal.methods.vre.closed_form import vre_columns
from accelcal.methods.vre.identify import row_space_basis
from accelcal.results import Reduction
from accelcal.uncertainty import McUncertainty, propagate

CHUNK_VALUES = 2**18
"""Most synthetic VRE values (trials times points) a sampler forms at once (2 MiB each array)."""


@dataclass(frozen=True)
class VreSampler:
    """Picklable sampler of re-identified synthetic VRE sets.

    Parameters
    ----------
    overload : numpy.ndarray
        Overload vectors, g, ``(n, 3)``.
    amplitude : numpy.ndarray
        Amplitudes, g, ``(n,)``.
    direction : numpy.ndarray
        Vibration directions, ``(n, 3)``.
    noise : numpy.ndarray
        Standard deviation of each VRE, g, ``(n,)``.
    terms : tuple of str
        Fitted coefficients.
    values : numpy.ndarray
        Their values generating the synthetic sets (row-space solution).
    operator : numpy.ndarray
        Linear map of VRE (after subtracting the fixed terms) to the
        estimates, ``(p, n)``.
    fixed : dict
        Coefficients held at known values.
    amplitude_sd, overload_sd : float
        Relative standard uncertainties of the amplitude and overload
        calibrations (fractions).
    priors : tuple of Prior
        The priors of terms left out of the fit, drawn in every trial.

    Calling ``sampler(rng, t)`` returns the errors ``(t, p)``.
    """

    overload: np.ndarray
    amplitude: np.ndarray
    direction: np.ndarray
    noise: np.ndarray
    terms: tuple
    values: np.ndarray
    operator: np.ndarray
    fixed: dict
    amplitude_sd: float = 0.0
    overload_sd: float = 0.0
    priors: tuple = ()

    def __call__(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Errors of ``t`` re-identified synthetic VRE sets, shape ``(t, p)``.

        The trials are formed in chunks of at most :data:`CHUNK_VALUES`
        values (trials times points), drawing the same random numbers in the
        same order as all at once: memory stays bounded for any number of
        points, and the results do not depend on the chunking.
        """
        n = self.amplitude.size
        scale_a = 1.0 + self.amplitude_sd * rng.standard_normal((t, 1))
        scale_b = 1.0 + self.overload_sd * rng.standard_normal((t, 1, 1))
        drawn = [(p.name, p.draw(rng, (t, 1))) for p in self.priors]
        coef = {**dict(zip(self.terms, self.values, strict=True)), **self.fixed}
        held = 0.0
        if self.fixed:
            nominal = vre_columns(self.overload, self.amplitude, self.direction)
            held = sum(v * nominal[k] for k, v in self.fixed.items())
        out = np.empty((t, self.values.size))
        step = max(1, CHUNK_VALUES // max(n, 1))
        for start in range(0, t, step):
            part = slice(start, min(t, start + step))
            cols = vre_columns(self.overload[None] * scale_b[part],
                               self.amplitude[None] * scale_a[part],
                               self.direction[None])  # Eqs. (9), (21) [Guan2021]
            y = sum((v * cols[k] for k, v in coef.items()), np.zeros((part.stop - start, n)))
            for name, v in drawn:
                y = y + v[part] * cols[name]
            y = y + self.noise * rng.standard_normal((part.stop - start, n))
            out[part] = (y - held) @ self.operator.T - self.values
        return out


def _operator(design: np.ndarray, sigma: np.ndarray | None, names) -> np.ndarray:
    """The identification's linear operator (row space of a deficient design), ``(p, n)``."""
    ident = analyse(design, names, sigma=sigma)
    w = np.ones(design.shape[0]) if sigma is None else 1.0 / sigma
    if ident.full_rank:
        return np.linalg.pinv(design * w[:, None]) * w
    basis = row_space_basis(ident.null_space)
    return basis @ np.linalg.pinv(design @ basis * w[:, None]) * w


def vre_uncertainty(
    reduction: Reduction,
    *,
    trials: int,
    seed: int,
    amplitude_sd: float = 0.0,
    overload_sd: float = 0.0,
    shortest: bool = False,
    progress=None,
    force: bool = False,
) -> McUncertainty:
    """Monte Carlo uncertainty of an identification by :func:`accelcal.methods.vre.identify`.

    Parameters
    ----------
    reduction : Reduction
        The identification of the measured VRE; its observations
        (``overload``, ``amplitude``, ``direction``, ``vre`` and, if given,
        ``uncertainty``) are the measured design.
    trials, seed : int
        Monte Carlo trials (> 0) and root seed.
    amplitude_sd, overload_sd : float
        Relative standard uncertainties of the amplitude and overload
        calibrations (fractions, e.g. 0.01 for 1 %).
    shortest : bool
        Shortest coverage interval instead of the symmetric one.
    progress : callable, optional
        ``progress(done, total)``.
    force : bool
        Run past the time bound (:func:`accelcal.uncertainty.propagate`).

    Returns
    -------
    McUncertainty
        One entry per fitted coefficient (NaN for the unidentifiable ones).

    Raises
    ------
    AccelcalError
        For negative or non-finite calibration uncertainties, or points
        without uncertainties and no residual degree of freedom.

    References
    ----------
    .. [1] JCGM 101:2008 (GUM-S1); Guan2021 eqs. (9), (21).
    """
    for value, what in ((amplitude_sd, "amplitude_sd"), (overload_sd, "overload_sd")):
        if not np.isfinite(value) or value < 0:
            raise AccelcalError(
                f"calibration uncertainty {value} must be a finite fraction >= 0",
                parameter=what,
            )
    est = reduction.estimate
    terms = est.names
    obs = reduction.observations
    a, b, d = obs["amplitude"], obs["overload"], obs["direction"]
    sigma = obs.get("uncertainty")
    if sigma is not None and (sigma <= 0).any():
        sigma = None  # as identify: noise-free points, the residuals set the scale
    cols = vre_columns(b, a, d)
    design = np.stack([np.broadcast_to(cols[k], a.shape) for k in terms], axis=1)
    y = obs["vre"] - sum((v * cols[k] for k, v in reduction.fixed.items()), np.zeros(a.size))
    op = _operator(design, sigma, terms)
    values = op @ y
    if sigma is None:
        if est.dof <= 0:
            raise AccelcalError(
                "the VRE points carry no uncertainty and the fit has no residual degree of "
                "freedom to estimate the noise; add points", parameter="uncertainty",
            )
        noise = np.full(a.size, np.sqrt(float(est.residuals @ est.residuals) / est.dof))
    else:
        noise = sigma
    priors = tuple(p for p in reduction.priors if p.name in cols)
    sampler = VreSampler(b, a, d, noise, terms, values, op, dict(reduction.fixed),
                         float(amplitude_sd), float(overload_sd), priors)
    inputs = ["VRE noise N(0, u_j) g" if sigma is not None else
              f"VRE noise N(0, {noise[0]:.3g}) g (residual level)"]
    if amplitude_sd > 0:
        inputs.append(f"amplitude calibration N(0, {amplitude_sd:.3g}) relative")
    if overload_sd > 0:
        inputs.append(f"overload calibration N(0, {overload_sd:.3g}) relative")
    if priors:
        inputs.append("terms left out drawn from their priors: " + ", ".join(
            f"{p.name} {p.distribution} {p.value:.3g} {p.unit}".rstrip() for p in priors))
    return propagate(sampler, est.values, est.std, names=terms, trials=trials, seed=seed,
                     units=dict(est.units), shortest=shortest, inputs=inputs, progress=progress,
                     force=force)
