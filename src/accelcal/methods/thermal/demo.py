"""The thermal test's part of the demo campaign (:mod:`accelcal.demo`).

The default accelerometer with the rig's default temperature terms (bias TC
8 ug/degC, scale-factor TC -25 ppm/degC, second-order terms and a
misalignment TC), a 600 s thermal lag, 10 ug of bias hysteresis, a 50 ug
warm-up with a 300 s time constant and 20 ug per degC/min of thermal
transient sensitivity, is taken through eight plateaus from -40 to 70 degC
and back (1 degC/min ramps, one-hour soaks), with a 12-position tumble of
3 readings per position at each; reduced with the order chosen by the
F-test.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, thermal tests.
.. [DOMAIN] accelcal domain notes, section 8.
"""

from functools import partial
from pathlib import Path

SETPOINTS = (-40.0, -10.0, 20.0, 50.0, 70.0, 35.0, 5.0, -25.0)
"""Plateaus of the demo, degC, in test order."""


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the file's laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("thermal chamber", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    import numpy as np

    from accelcal.defaults import default_model
    from accelcal.io.formats import thermal as thermal_format
    from accelcal.rigs.thermal import DEFAULT_TEMPERATURE, Programme, simulate

    rng = np.random.default_rng(seed)
    model = default_model().replace(temperature=DEFAULT_TEMPERATURE)
    programme = Programme(setpoints=SETPOINTS, warmup=1800.0, points=12, dwell=30.0)
    rec = simulate(model, programme, noise=2e-5, warmup_amplitude=5e-5, warmup_tau=300.0,
                   hysteresis=1e-5, hysteresis_scale=5e-6, rate_sensitivity=2e-5, seed=rng)
    info = lab(date, serial)
    rec = type(rec)(rec.t, rec.phase, rec.plateau, rec.angle_rad, rec.output, rec.temperature,
                    rec.rotation_axis, rec.output_unit, rec.setpoints, rec.start, rec.chamber,
                    {**rec.metadata, **info})
    path = data_dir / "thermal.csv"
    thermal_format.write(path, rec)
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.io.formats import thermal as thermal_format
    from accelcal.methods.thermal import reduce_thermal
    from accelcal.pipeline import Outcome

    red = reduce_thermal(thermal_format.read(path))
    return [Outcome(red, red.to_records(lab_info([path]), input_files=[path]), "thermal")]
