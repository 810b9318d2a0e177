"""Acceptance-test rigs: a centrifuge driven past full scale, and repeated turn-ons.

range
    A centrifuge (IA radial: the input is ``omega^2 r``, along the IA) dwells
    at zero input (at rest), then at each input of a ladder up to and past
    full scale, at rest again, the same ladder with the sensor turned round
    (negative inputs), and at rest a last time. The sensor (physical model):
    the pendulum senses ``x = a + K2 a^2``; the rebalance loop's torquer
    current saturates softly, ``y = x / (1 + |x / FS|^p)^(1/p)`` (FS the
    full scale, p the knee's sharpness: the relative compression is
    ``|x / FS|^p / p`` well below FS, so the nonlinearity grows steeply near
    full scale); the output ``E = K0 + K1 (y + s) + noise`` is clipped at
    the amplifier's or DAQ's rail ``+-rail``. Once the input has passed full
    scale the loop has lost lock and the pendulum has struck its stops:
    from then on the bias is shifted by ``s = overload_shift`` (g).
turn-on
    ``turn_ons`` power cycles (cooled down between them, ``gap`` s); in
    each, ``pairs`` dwells at +1 g then -1 g (the indexing head's IA up and
    down). Turn-on j has its own bias ``b_j ~ N(K0, bias_sd^2)`` (g) and
    scale factor ``k_j = K1 (1 + e_j)``, ``e_j ~ N(0, scale_sd^2)``, and a
    bias drifting in the run at ``drift`` g/h: ``E = k_j (b_j + drift t + a)
    + noise``, t the time since turn-on.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, input range, turn-on repeatability tests.
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.acceptance import StepRecord
from accelcal.resources import generator

RANGE_LADDER_G = (1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 24.0, 27.0, 30.0, 33.0, 36.0, 40.0, 45.0,
                  50.0, 55.0, 60.0)
"""Default centrifuge inputs, g (one side)."""

RANGE_LIMIT = 1e-3
"""Default nonlinearity limit (relative to the input) the range is stated at."""


def _check(**values) -> None:
    limits = {"dwell": (1e-3, 1e5), "rate": (1e-3, 1e6), "noise": (0.0, 1e3),
              "full_scale": (1e-3, 1e4), "knee": (1.0, 100.0), "k2": (-1.0, 1.0),
              "overload_shift": (-1.0, 1.0), "limit": (1e-9, 0.5), "scale_factor": (-1e6, 1e6),
              "bias": (-1e6, 1e6), "turn_ons": (1, 1000), "pairs": (1, 1000),
              "bias_sd": (0.0, 1.0), "scale_sd": (0.0, 1.0), "drift": (-1.0, 1.0),
              "gap": (0.0, 1e7), "rail": (0.0, 1e9)}
    for name, value in values.items():
        if value is None:
            continue
        lo, hi = limits[name]
        if isinstance(value, bool) or not isinstance(value, int | float) or not lo <= value <= hi:
            raise AccelcalError(f"{name} {value!r:.30} is not a number in [{lo:g}, {hi:g}]",
                                parameter=name)
    if values.get("scale_factor") == 0:
        raise AccelcalError("the scale factor must not be 0", parameter="scale_factor")
    if values["dwell"] * values["rate"] < 3:
        raise AccelcalError("dwell * rate must give at least three samples per dwell",
                            parameter="dwell")


def saturate(a, *, k2: float, full_scale: float, knee: float) -> np.ndarray:
    """The input the rebalance loop reproduces, g: soft saturation of ``a + K2 a^2``."""
    x = np.asarray(a, dtype=float) + k2 * np.asarray(a, dtype=float) ** 2
    return x / (1.0 + np.abs(x / full_scale) ** knee) ** (1.0 / knee)


def true_range(*, k2: float, full_scale: float, knee: float, limit: float, sign: float) -> float:
    """The input (g, signed) where ``|y / a - 1|`` first exceeds ``limit`` (bisection)."""
    a = sign * np.geomspace(1e-3, 10.0 * full_scale, 20001)
    n = np.abs(saturate(a, k2=k2, full_scale=full_scale, knee=knee) / a - 1.0)
    k = int(np.argmax(n > limit))
    lo, hi = a[k - 1], a[k]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if abs(saturate(mid, k2=k2, full_scale=full_scale, knee=knee) / mid - 1.0) > limit:
            hi = mid
        else:
            lo = mid
    return float(0.5 * (lo + hi))


def simulate_range(*, scale_factor: float = 0.2, bias: float = 1e-3, output_unit: str = "V",
                   inputs=RANGE_LADDER_G, full_scale: float = 50.0, knee: float = 10.0,
                   k2: float = 10e-6, rail: float | None = 9.5, overload_shift: float = 20e-6,
                   dwell: float = 5.0, rate: float = 20.0, noise: float = 4e-6,
                   limit: float = RANGE_LIMIT, seed=None) -> StepRecord:
    """A simulated input-range test on a centrifuge (module docs).

    Parameters
    ----------
    scale_factor, bias : float
        K1 (output unit per g) and K0 (output unit).
    output_unit : str
    inputs : sequence of float
        The ladder of inputs, g, positive and ascending (run on both sides).
    full_scale, knee, k2 : float
        Saturation level (g), the knee's sharpness p, K2 (g/g^2).
    rail : float or None
        Clipping level of the output, output unit (None: no clipping).
    overload_shift : float
        Bias shift once the input has passed full scale, g.
    dwell, rate, noise : float
        Time per dwell (s), sample rate (Hz), output noise SD (output unit).
    limit : float
        The nonlinearity limit the truth in the metadata is stated at.
    seed : int, numpy.random.SeedSequence or numpy.random.Generator, optional

    Returns
    -------
    StepRecord
        Test ``range``; metadata ``rail`` and the truth: ``true_range_g``
        (``[negative, positive]`` inputs where ``|y/a - 1|`` reaches
        ``range_limit``) and ``true_overload_shift_g``.
    """
    _check(scale_factor=scale_factor, bias=bias, full_scale=full_scale, knee=knee, k2=k2,
           rail=rail, overload_shift=overload_shift, dwell=dwell, rate=rate, noise=noise,
           limit=limit)
    ladder = np.asarray(inputs, dtype=float)
    if not (ladder.size >= 3 and np.all(ladder > 0) and np.all(np.diff(ladder) > 0)
            and ladder[-1] <= 1000.0):
        raise AccelcalError("the range ladder needs at least three positive, ascending inputs "
                            "up to 1000 g", parameter="inputs")
    n = round(dwell * rate)
    if (2 * ladder.size + 3) * n > 20_000_000:
        raise AccelcalError("the test would take more than 2e7 samples: shorten the dwell or "
                            "the rate", parameter="dwell")
    rng = generator(seed)
    applied = np.r_[0.0, ladder, 0.0, -ladder, 0.0]
    over = np.abs(applied) > full_scale
    shifted = np.cumsum(over) > 0
    y = saturate(applied, k2=k2, full_scale=full_scale, knee=knee) + overload_shift * shifted
    out = bias + scale_factor * np.repeat(y, n) + rng.normal(0.0, noise, applied.size * n)
    if rail is not None:
        out = np.clip(out, -rail, rail)
    truth = [true_range(k2=k2, full_scale=full_scale, knee=knee, limit=limit, sign=s)
             for s in (-1.0, 1.0)]
    meta = {"simulated": True, "seed": seed if isinstance(seed, int) else None,
            "rail": rail, "range_limit": limit, "true_range_g": truth,
            "true_overload_shift_g": overload_shift if shifted.any() else 0.0,
            "settings": {"full_scale_g": full_scale, "knee": knee, "k2": k2, "bias": bias,
                         "dwell_s": dwell, "rate_hz": rate, "noise": noise,
                         "inputs_g": ladder.tolist()}}
    return StepRecord(t=np.arange(out.size) / rate, input=np.repeat(applied, n), output=out,
                      test="range", output_unit=output_unit, scale_factor=scale_factor,
                      metadata=meta)


def simulate_turn_on(*, scale_factor: float = 1.0, bias: float = 50e-6, output_unit: str = "g",
                     turn_ons: int = 8, pairs: int = 4, dwell: float = 30.0, rate: float = 10.0,
                     noise: float = 20e-6, bias_sd: float = 15e-6, scale_sd: float = 30e-6,
                     drift: float = 10e-6, gap: float = 3600.0, seed=None) -> StepRecord:
    """Simulated repeated turn-ons on the indexing head (module docs).

    Parameters
    ----------
    scale_factor, bias : float
        K1 (output unit per g) and the mean bias K0 (g).
    output_unit : str
    turn_ons, pairs : int
        Power cycles, and +1 g / -1 g dwell pairs in each.
    dwell, rate, noise : float
        Time per dwell (s), sample rate (Hz), output noise SD (output unit).
    bias_sd, scale_sd : float
        SD of the bias (g) and of the relative scale factor between turn-ons.
    drift : float
        In-run bias drift, g per hour.
    gap : float
        Time between turn-ons (cool-down), s.
    seed : int, numpy.random.SeedSequence or numpy.random.Generator, optional

    Returns
    -------
    StepRecord
        Test ``turn-on`` with a ``turn_on`` column; metadata the truth:
        ``true_bias_g`` and ``true_scale_factor`` per turn-on, the
        population ``true_bias_sd_g``, ``true_scale_sd`` and ``true_drift_g_per_h``.
    """
    _check(scale_factor=scale_factor, bias=bias, turn_ons=turn_ons, pairs=pairs, dwell=dwell,
           rate=rate, noise=noise, bias_sd=bias_sd, scale_sd=scale_sd, drift=drift, gap=gap)
    n = round(dwell * rate)
    if turn_ons * pairs * 2 * n > 20_000_000:
        raise AccelcalError("the test would take more than 2e7 samples: fewer turn-ons, "
                            "shorter dwells or a lower rate", parameter="turn_ons")
    rng = generator(seed)
    b = bias + bias_sd * rng.standard_normal(turn_ons)
    k = scale_factor * (1.0 + scale_sd * rng.standard_normal(turn_ons))
    a = np.tile(np.repeat([1.0, -1.0], n), pairs)
    t_run = np.arange(a.size) / rate
    span = t_run[-1] + 1.0 / rate + gap
    t, inputs, out, label = [], [], [], []
    for j in range(turn_ons):
        t.append(j * span + t_run)
        inputs.append(a)
        out.append(k[j] * (b[j] + drift * t_run / 3600.0 + a)
                   + rng.normal(0.0, noise, a.size))
        label.append(np.full(a.size, j + 1.0))
    meta = {"simulated": True, "seed": seed if isinstance(seed, int) else None,
            "true_bias_g": b.tolist(), "true_scale_factor": k.tolist(),
            "true_bias_sd_g": bias_sd, "true_scale_sd": scale_sd,
            "true_drift_g_per_h": drift,
            "settings": {"turn_ons": turn_ons, "pairs": pairs, "dwell_s": dwell,
                         "rate_hz": rate, "noise": noise, "gap_s": gap}}
    return StepRecord(t=np.concatenate(t), input=np.concatenate(inputs),
                      output=np.concatenate(out), test="turn-on", output_unit=output_unit,
                      scale_factor=scale_factor, turn_on=np.concatenate(label), metadata=meta)


__all__ = ["RANGE_LADDER_G", "RANGE_LIMIT", "saturate", "simulate_range", "simulate_turn_on",
           "true_range"]
