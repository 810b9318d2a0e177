"""Acceptance-test rigs: a calibration before and after an environment, and Helmholtz coils.

environment
    One accelerometer (one serial) is calibrated by a multipoint tumble
    (:func:`accelcal.rigs.tumble.simulate`, IA turned about the OA through
    ``positions`` equally spaced angles, ``repeats`` readings at each), then
    put through an environment (shock, vibration or a thermal cycle) that
    shifts its coefficients by ``shift``, then calibrated again the same
    way. Each calibration has its own noise (independent draws of the
    reading noise ``sigma``). :func:`accelcal.methods.acceptance.environment.simulate_pair`
    reduces the two tumble records to calibration records.
magnetic
    Helmholtz coils apply a uniform field B (mT) along each axis of the
    sensor in turn (x = IA, y = PA, z = OA), stepping it through
    ``fields`` (mT) and back to zero, with the IA horizontal (no gravity
    input). The sensor (physical model: the torquer's permanent magnet and
    the pendulum's magnetic parts give an output linear in the field,
    IEEE 1293 magnetic sensitivity): ``E = K1 (K0 + m . B) + noise``, m the
    magnetic sensitivity vector (g/mT). Recorded as a step record (test
    ``magnetic``) with the field columns ``field_x, field_y, field_z`` (mT).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, tests after environmental exposure and
   magnetic sensitivity.
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.resources import generator

ENV_POSITIONS = 24
"""Default tumble positions of each calibration."""

SHIFT_UNITS = {"ug": 1e-6, "mg": 1e-3, "g": 1.0, "urad": 1e-6, "ppm": 1e-6}
"""Units of a coefficient shift (``ppm`` for the scale factor K1 only: relative)."""


MAGNETIC_FIELDS_MT = (-1.0, -0.5, 0.5, 1.0)
"""Default field steps of the Helmholtz coils, mT."""

AXES = ("x", "y", "z")
"""The field axes: x along the IA, y along the PA, z along the OA."""


def parse_shift(text: str) -> dict:
    """``"K0=30ug,K1=50ppm"`` -> ``{"K0": 3e-5, "K1": 5e-5}`` (K1 relative, others in g/g^n).

    Raises
    ------
    AccelcalError
        For an unknown coefficient or unit, or a value that is not a number.
    """
    from accelcal.model import TERMS

    out = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        name, _, value = part.partition("=")
        name, value = name.strip(), value.strip()
        unit = next((u for u in sorted(SHIFT_UNITS, key=len, reverse=True)
                     if value.endswith(u)), None)
        if name not in TERMS or name == "sigma":
            raise AccelcalError(f"{part[:30]!r}: {name[:12]!r} is not a coefficient "
                                "(K0, K1, K2, ...)", parameter="shift")
        if unit is None or (unit == "ppm") != (name == "K1"):
            raise AccelcalError(f"{part[:30]!r}: give K1 in ppm and the others in ug, "
                                "mg, g or urad (e.g. K0=30ug,K1=50ppm)", parameter="shift")
        try:
            number = float(value[: -len(unit)])
        except ValueError:
            raise AccelcalError(f"{part[:30]!r} is not NAME=NUMBERUNIT",
                                parameter="shift") from None
        if not np.isfinite(number) or abs(number * SHIFT_UNITS[unit]) > 0.1:
            raise AccelcalError(f"{part[:30]!r} must be finite and below 0.1 g "
                                "(1e5 ppm)", parameter="shift")
        out[name] = number * SHIFT_UNITS[unit]
    return out


def simulate_environment(shift=None, *, model=None, positions: int = ENV_POSITIONS,
                         repeats: int = 4, noise: float = 5e-6, seed=None) -> tuple:
    """The tumble records of two calibrations around an environment (module docs).

    Parameters
    ----------
    shift : dict, optional
        Coefficient -> shift (g/g^n; K1 relative), e.g. from :func:`parse_shift`.
    model : accelcal.model.ErrorModel, optional
        The sensor before the environment (default K0 = 100 ug, K1 = 1.25
        V/g, K2 = 10 ug/g^2).
    positions, repeats : int
        Tumble positions and readings at each.
    noise : float
        Reading noise SD, g.
    seed : int, SeedSequence or Generator, optional

    Returns
    -------
    tuple of accelcal.io.formats.tumble.TumbleRecord
        ``(before, after)``, each with its own noise.
    """
    import dataclasses

    from accelcal.model import ErrorModel
    from accelcal.rigs.tumble import simulate as tumble_simulate

    shift = dict(shift or {})
    if not (isinstance(positions, int) and 8 <= positions <= 3600):
        raise AccelcalError(f"positions {positions!r:.20} must be a whole number in [8, 3600]",
                            parameter="positions")
    if not (isinstance(repeats, int) and 1 <= repeats <= 1000):
        raise AccelcalError(f"repeats {repeats!r:.20} must be a whole number in [1, 1000]",
                            parameter="repeats")
    if not 0.0 < noise <= 1e-2:
        raise AccelcalError(f"noise {noise:g} g must be in (0, 0.01]", parameter="noise")
    base = model or ErrorModel(K0=100e-6, K1=1.25, K2=10e-6)
    changed = {k: getattr(base, k) + v for k, v in shift.items() if k != "K1"}
    if "K1" in shift:
        changed["K1"] = base.K1 * (1.0 + shift["K1"])
    models = (dataclasses.replace(base, sigma=noise),
              dataclasses.replace(base, sigma=noise, **changed))
    rng = generator(seed)
    angles = np.radians(np.arange(positions) * 360.0 / positions)
    return tuple(tumble_simulate(angles, m, repeats=repeats, seed=rng) for m in models)


def simulate_magnetic(sensitivity=(20e-6, 5e-6, 8e-6), *, fields=MAGNETIC_FIELDS_MT,
                      scale_factor: float = 1.25, bias: float = 100e-6, output_unit: str = "V",
                      dwell: float = 10.0, rate: float = 10.0, noise: float = 5e-6,
                      seed=None):
    """A simulated magnetic-sensitivity test in Helmholtz coils (module docs).

    A dwell at zero field, then along each axis in turn one at each of
    ``fields`` and one at zero field (every dwell ``dwell`` s).

    Parameters
    ----------
    sensitivity : sequence of 3 float
        The magnetic sensitivity vector m along the IA, PA, OA, g/mT.
    fields : sequence of float
        Field steps, mT (at least one non-zero).
    scale_factor, bias : float
        K1 (output unit per g) and K0 (g).
    output_unit : str
    dwell, rate, noise : float
        Time per dwell (s), sample rate (Hz), output noise SD (g).
    seed : int, SeedSequence or Generator, optional

    Returns
    -------
    accelcal.io.formats.acceptance.StepRecord
        Test ``magnetic``, input 0 g; metadata ``true_sensitivity_g_per_mT``,
        ``fields_mT``, ``simulated``, ``seed`` (an int seed).
    """
    from accelcal.io.formats.acceptance import StepRecord

    m = np.asarray(sensitivity, dtype=float).reshape(-1)
    steps = np.asarray(fields, dtype=float).reshape(-1)
    if m.size != 3 or not np.all(np.isfinite(m)) or np.abs(m).max() > 1.0:
        raise AccelcalError("the sensitivity is three finite numbers below 1 g/mT",
                            parameter="sensitivity")
    if not steps.size or not np.all(np.isfinite(steps)) or not np.any(steps != 0.0) \
            or np.abs(steps).max() > 100.0:
        raise AccelcalError("the field steps are finite numbers up to 100 mT, one non-zero",
                            parameter="fields")
    n = round(dwell * rate)
    if n < 3 or not 0.0 < rate <= 1e5:
        raise AccelcalError("dwell * rate must give at least three samples per dwell",
                            parameter="dwell")
    if not 0.0 <= noise <= 1e-2 or scale_factor == 0 or not np.isfinite(scale_factor):
        raise AccelcalError("the noise is in [0, 0.01] g and the scale factor non-zero",
                            parameter="noise")
    levels = [np.zeros(3)]
    for axis in range(3):
        for b in (*steps, 0.0):
            vec = np.zeros(3)
            vec[axis] = b
            levels.append(vec)
    field = np.repeat(np.asarray(levels), n, axis=0)
    rng = generator(seed)
    out = scale_factor * (bias + field @ m + noise * rng.standard_normal(len(field)))
    meta = {"simulated": True, "true_sensitivity_g_per_mT": m.tolist(),
            "fields_mT": steps.tolist(), "noise_sd_g": noise}
    if isinstance(seed, int):
        meta["seed"] = seed
    return StepRecord(t=np.arange(len(field)) / rate, input=np.zeros(len(field)), output=out,
                      test="magnetic", output_unit=output_unit, scale_factor=scale_factor,
                      field=field, metadata=meta)
