"""The centrifuge's part of the demo campaign (:mod:`accelcal.demo`).

The default accelerometer on a 1.5 m arm in the seven named positions at 5
to 50 g (two one-revolution readings per step after a marked spin-up
reading), with a radius error of 150 ppm, arm stretch, misalignments of 0.1 µrad (a
misalignment of 1 µrad would put 50 µg on IA at 50 g in the OA and PA radial
positions),
spin-axis tilt and rate ripple; a 24-position 1 g tumble of the same sensor
beside it. The two records are reduced jointly: K1 and K0 from the tumble,
K2, K3, K4, the cross-coupling, the radius error and the arm stretch from the
centrifuge.

References
----------
.. [IEEE836] IEEE Std 836-2009, Recommended Practice for Precision Centrifuge
   Testing of Linear Accelerometers.
"""

import dataclasses
from functools import partial
from pathlib import Path

import numpy as np

POSITIONS = ("IA-in", "IA-out", "OA-in", "OA-out", "PA-in", "PA-out", "IA-tan")
LEVELS = tuple(np.arange(5.0, 55.0, 5.0))
RIG = {"radius": 1.5, "radius_error": 1.5e-4, "arm_stretch": 2e-8, "tilt": 1e-4,
       "ripple": 1e-4}
ESTIMATE = ("radius_error", "arm_stretch")
"""Rig errors the joint reduction estimates (the misalignments are given by the survey)."""
MISALIGNMENT_SD = 1e-7
"""Misalignment of the sensor on the arm at each position (drawn), rad; the survey's SD."""


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the files' laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("centrifuge + 1 g tumble", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    from accelcal.defaults import default_model
    from accelcal.io.formats import centrifuge, tumble
    from accelcal.rigs.centrifuge import CentrifugeRig, simulate
    from accelcal.rigs.tumble import simulate as simulate_tumble
    from accelcal.rigs.tumble import uniform_positions

    rng = np.random.default_rng(seed)
    info = lab(date, serial)
    model = default_model()
    mis = {p: rng.normal(0.0, MISALIGNMENT_SD, 3) for p in POSITIONS}
    rig = CentrifugeRig(misalignment=mis, gravity=info["local_gravity"], **RIG)
    rec = simulate(model, POSITIONS, LEVELS, rig=rig, readings=2, spinup=1, seed=rng,
                   survey={"radius_error": {"value": 0.0, "sd": 3e-4},
                           "misalignment": {"value": 0.0, "sd": MISALIGNMENT_SD}})
    path = data_dir / "centrifuge.csv"
    centrifuge.write(path, dataclasses.replace(rec, metadata={**rec.metadata, **info}))
    one = simulate_tumble(uniform_positions(24), model, seed=rng)
    one = type(one)(one.angles_rad, one.outputs, one.rotation_axis, one.output_unit,
                    {**one.metadata, **info})
    tumble.write(data_dir / "centrifuge-1g.csv", one)
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.io.formats import centrifuge
    from accelcal.methods.centrifuge import read_one_g, reduce_joint
    from accelcal.pipeline import Outcome

    one_path = path.with_name("centrifuge-1g.csv")
    red = reduce_joint(centrifuge.read(path), read_one_g(one_path), estimate=ESTIMATE)
    files = [path, one_path]
    return [Outcome(red, red.to_records(lab_info(files), input_files=files), "centrifuge")]
