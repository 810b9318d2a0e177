"""The indexing head's part of the demo campaign (:mod:`accelcal.demo`).

Four sensors at mount phases 0, 90, 180 and 270 deg, 24 positions, head
error uniform within ±2 arcsec plus the first harmonic Dong2014 measured
(given in the file as measured, SD 5e-7 rad), output noise 2.8e-6 V
(Dong2014 Table 1); joint reduction. The sensors are the default
accelerometer and three variants whose eq. (5) coefficients are Dong2014
Table 1's sensors 2-4 (their other terms are the default's, and fold into
K_F, K_I and K_II by a few µV, as they would in a real test).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, Table 1 and section 3.
"""

from functools import partial
from pathlib import Path

import numpy as np

POSITIONS = 24
ANGLE_ERROR_ARCSEC = 2.0
FIRST_HARMONIC_SD_RAD = 5e-7
"""SD of the measured first harmonic (Dong2014 section 3 gives 5e-7 rad)."""


def head_models():
    """The four sensors on the head: the default model and Dong2014 Table 1's sensors 2-4.

    References
    ----------
    .. [1] Dong2014, Table 1 (B_z): K_F, K_I, K_O, K_IO, K_II of sensors 2-4.
    """
    from accelcal.defaults import default_model
    from accelcal.model import ErrorModel
    from accelcal.rigs.dividing_head import DONG2014_TABLE1

    base = default_model()
    models = [base]
    for row in DONG2014_TABLE1[1:]:
        dong = ErrorModel.from_dong2014(**row)
        models.append(base.replace(K0=dong.K0, K1=dong.K1, Ko=dong.Ko, Kio=dong.Kio, K2=dong.K2))
    return tuple(models)


def stage(serials, lab):
    """The campaign stage: ``lab(date, serial)`` gives the files' laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("indexing head", partial(_simulate, serials=tuple(serials), lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serials, lab) -> Path:
    from accelcal.io.formats.dividing_head import write_head_record
    from accelcal.rigs.dividing_head import (
        DONG2014_FIRST_HARMONIC,
        DONG2014_NOISE_V,
        AngleErrorProfile,
        DividingHeadRig,
        simulate,
    )
    from accelcal.units import ARCSEC

    models = head_models()
    rig = DividingHeadRig.uniform(
        POSITIONS, models, angle_error=AngleErrorProfile.uniform(ANGLE_ERROR_ARCSEC * ARCSEC),
        first_harmonic=DONG2014_FIRST_HARMONIC, noise=DONG2014_NOISE_V,
    )
    sim = simulate(rig, np.random.default_rng(seed))
    path = data_dir / "indexing_head.csv"
    write_head_record(
        path, rig.positions, sim.outputs, rig.mounts,
        sensors=[f"U{k + 1}" for k in range(len(models))], output_unit="V",
        nominal_scale_factors=[m.K1 for m in models],
        first_harmonic=DONG2014_FIRST_HARMONIC, first_harmonic_sd=FIRST_HARMONIC_SD_RAD,
        simulation={"models": [m.to_dict() for m in models],
                    "eta_rad": rig.eta.tolist(), "angle_error_rad": sim.d_alpha.tolist(),
                    "seed": str(seed.entropy),
                    "description": "accelcal demo: uniform +-2 arcsec head error plus "
                                   "Dong2014's first harmonic, noise 2.8e-6 V"},
        lab=lab(date, list(serials)),
    )
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.methods.dividing_head import HeadData, options_from_record, reduce
    from accelcal.pipeline import Outcome

    rec = read_head_record(path)
    red = reduce(HeadData.from_record(rec), "joint", **options_from_record(rec, "joint"))
    records = red.to_records(lab_info([path], sensors=len(rec.sensors)), input_files=[path])
    truth = None
    if rec.simulation:
        truth = np.asarray(rec.simulation["angle_error_rad"], dtype=float)
    return [Outcome(red, records, "head", {"truth": truth})]
