"""Monte Carlo check of a plan: the rig and the reduction, repeated.

:class:`PlanSampler` draws, per trial, the rig's errors from the plan's
uncertainties (radius error, stretch, proof-mass offset, misalignment;
Gaussian), simulates the test with noise (:mod:`accelcal.rigs.centrifuge`,
plus a 1 g tumble for a joint plan), reduces it as a laboratory would (the
rig errors given as 0 with the plan's SDs, the estimated ones estimated)
and returns the errors of the estimates. :func:`plan_monte_carlo` runs it on
the engine of :mod:`accelcal.montecarlo` (seeded blocks, streaming
moments): its standard deviations are what the plan predicts, within the
sampling error ``1 / sqrt(2 (M - 1))`` of an SD from M trials.

References
----------
.. [GUM-S1] JCGM 101:2008, secs. 5-7.
.. [DOMAIN] accelcal domain notes, section 9.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal.model import ErrorModel
from accelcal.montecarlo import MonteCarloResult, run


@dataclass(frozen=True)
class PlanSampler:
    """Picklable sampler: ``sampler(rng, t)`` returns the estimation errors, shape ``(t, p)``.

    Parameters mirror :func:`~accelcal.methods.centrifuge.plan.plan`; ``model``
    is the true sensor (default: unit sensor, output in g).
    """

    positions: tuple
    levels: tuple
    terms: tuple
    estimate: tuple = ()
    noise_sd: float = 1e-6
    readings: int = 1
    radius: float = 1.0
    sds: dict = field(default_factory=dict)
    one_g_positions: int = 0
    model: ErrorModel = field(default_factory=lambda: ErrorModel(K1=1.0, output_unit="g"))

    def __call__(self, rng: np.random.Generator, t: int) -> np.ndarray:
        """Errors of ``t`` simulated and reduced tests."""
        from accelcal.methods.centrifuge.joint import reduce_joint
        from accelcal.methods.centrifuge.reduce import reduce_centrifuge
        from accelcal.rigs.centrifuge import CentrifugeRig, simulate
        from accelcal.rigs.tumble import simulate as tumble
        from accelcal.rigs.tumble import uniform_positions

        truth = self.model.terms()
        out = np.empty((t, len(self.terms) + len(self.estimate)))
        names = [p if isinstance(p, str) else p["name"] for p in self.positions]
        for k in range(t):
            draw = {n: float(rng.normal(0.0, self.sds.get(n, 0.0))) for n in
                    ("radius_error", "arm_stretch", "proof_mass_offset")}
            mis = {p: rng.normal(0.0, self.sds.get("misalignment", 0.0), 3) for p in names}
            rig = CentrifugeRig(radius=self.radius, misalignment=mis, **draw)
            rec = simulate(self.model, self.positions, self.levels, rig=rig,
                           readings=self.readings, noise=self.noise_sd * abs(self.model.K1),
                           seed=rng)
            given = {n: (0.0, sd) for n, sd in self.sds.items() if sd > 0 and n not in
                     self.estimate}
            if self.one_g_positions:
                one = tumble(uniform_positions(self.one_g_positions), self.model,
                             noise=self.noise_sd * abs(self.model.K1), seed=rng)
                red = reduce_joint(rec, one, terms=self.terms, estimate=self.estimate,
                                   rig_errors=given)
            else:
                red = reduce_centrifuge(rec, terms=self.terms, estimate=self.estimate,
                                        rig_errors=given)
            got = red.estimate.values.copy()
            want = np.array([truth[n] for n in self.terms])
            i1 = self.terms.index("K1")
            got[i1], want[i1] = got[i1] / want[i1], 1.0  # K1 relative, as the plan states it
            rig_err = [red.shared[n] - draw[n] for n in self.estimate] if self.estimate else []
            out[k] = np.concatenate([got - want, rig_err])
        return out


def plan_monte_carlo(sampler: PlanSampler, trials: int, seed: int, **options
                     ) -> MonteCarloResult:
    """Run ``sampler`` on the Monte Carlo engine (``options``: :func:`accelcal.montecarlo.run`).

    References
    ----------
    .. [1] JCGM 101:2008 (GUM-S1), 7.2-7.6.
    """
    names = (*sampler.terms, *sampler.estimate)
    return run(sampler, trials, names=names, seed=seed, block_size=min(256, trials), **options)
