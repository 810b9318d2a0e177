"""The shaker's part of the demo campaign (:mod:`accelcal.demo`).

The default accelerometer vibrated at 5 g and 160 Hz along 12 directions
30 deg apart in the transverse plane, 16 periods at 10240 Hz; k_o, k_p,
k_oo, k_pp, k_op from the w and 2w phasors.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers.
"""

from functools import partial
from pathlib import Path

import numpy as np

SHAKER = {"amplitude": 5.0, "frequency": 160.0, "sample_rate": 10240.0, "periods": 16.0}
ANGLES_DEG = np.arange(0.0, 360.0, 30.0)


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the files' laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("shaker sweep", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    import shutil

    from accelcal.defaults import default_model
    from accelcal.io.formats.shaker import write_records
    from accelcal.methods.transverse import axial_sensitivity
    from accelcal.rigs.shaker import ShakerRig

    model = default_model()
    records = ShakerRig(**SHAKER).simulate(model, np.deg2rad(ANGLES_DEG),
                                           rng=np.random.default_rng(seed))
    directory = data_dir / "shaker"
    if directory.exists():
        shutil.rmtree(directory)
    extra = {"axial_sensitivity": {d: axial_sensitivity(model, d) for d in ("eq20", "symmetric")},
             "source": "accelcal demo", **lab(date, serial)}
    write_records(records, directory, extra=extra)
    return directory


def _reduce(directory: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.io.formats.shaker import read_records, shaker_files
    from accelcal.methods.transverse import identify
    from accelcal.pipeline import Outcome

    files = shaker_files(directory)
    info = lab_info([f for group in files.values() for f in group])
    out = []
    for rec in read_records(directory):
        red = identify(rec, route="2w")
        records = red.to_records(info, input_files=files[rec.amplitude])
        out.append(Outcome(red, records, f"shaker-{red.assumed('amplitude'):g}g"))
    return out
