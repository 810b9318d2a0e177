"""A straightforward per-trial indexing-head study: the benchmark's reference.

Each trial is reduced by the public one-record functions
(:func:`accelcal.methods.dividing_head.single`, ``four``, ``joint``) in a
Python loop, exactly as a user would script it. It draws its random numbers
as :meth:`accelcal.methods.dividing_head.HeadStudy.draw` does (one
sub-block of at most ``SUB_BLOCK`` trials from seed block 0), so for the
same seed it sees the same trials as the vectorised study and must give
the same RMS errors and mean formal SDs.
"""

import numpy as np

from accelcal.methods.dividing_head import (
    COEFFICIENTS,
    SUB_BLOCK,
    HeadData,
    HeadStudy,
    four,
    joint,
    single,
)
from accelcal.montecarlo import block_generator


def naive_study(rig, trials: int, seed: int, methods, h1_sd: float = 0.0):
    """RMS errors and mean formal SDs ``(methods, K, 5)``, one trial at a time."""
    if trials > SUB_BLOCK:
        raise ValueError(f"at most {SUB_BLOCK} trials (one sub-block of seed block 0)")
    d, noise, h1_noise = HeadStudy(rig, methods, h1_sd).draw(block_generator(seed, 0), trials)
    coef = np.array([[m.to_dong2014()[c] for c in COEFFICIENTS] for m in rig.models])
    c = np.stack([np.ones_like(rig.positions), np.cos(rig.positions), np.sin(rig.positions)], 1)
    gauge = np.linalg.pinv(c)
    sq = np.zeros((len(methods), rig.n_sensors, 5))
    sd = np.zeros_like(sq)
    for t in range(trials):
        u = rig.outputs(d[t])[0] + noise[t]
        data = HeadData.build(rig.positions, u, rig.mounts)
        d0, d1c, d1s = gauge @ d[t]
        h1 = (d1c + h1_sd * h1_noise[t, 0], d1s + h1_sd * h1_noise[t, 1])
        truth = coef.copy()
        truth[:, 2] += coef[:, 1] * (rig.eta + d0)
        for m, name in enumerate(methods):
            if name == "single":
                result = single(data)
            else:
                reduce = four if name.startswith("four") else joint
                known = name.endswith("_known_h1")
                result = reduce(data, first_harmonic=h1 if known else None,
                                first_harmonic_sd=h1_sd if known else 0.0)
            values = np.array([e.values for e in result.sensors])
            sq[m] += (values - truth) ** 2
            sd[m] += np.array([e.std for e in result.sensors])
    return np.sqrt(sq / trials), sd / trials
