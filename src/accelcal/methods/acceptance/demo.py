"""The acceptance tests' part of the demo campaign (:mod:`accelcal.demo`).

Three acceptance tests of the default accelerometer: the threshold on the
indexing head (a 10 ug break-away level at null, the default ladder of
0.5 to 12 arcsec), the input range on a centrifuge (saturation at 50 g,
clipping at the DAQ's rail, a 20 ug bias shift after the overload) and
eight turn-ons at +1 g and -1 g (bias SD 15 ug, scale-factor SD 30 ppm,
10 ug/h in-run drift). Each is written as a step record and reduced.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, threshold, input range and turn-on tests.
"""

import dataclasses
from functools import partial
from pathlib import Path

TESTS = {"threshold": {"dwell": 10.0, "breakaway": 10e-6},
         "range": {"dwell": 5.0, "rate": 20.0},
         "turn-on": {"dwell": 10.0}}
"""The tests simulated and their rig settings (:func:`accelcal.methods.acceptance.simulate`)."""


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the files' laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("acceptance tests", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    import numpy as np

    from accelcal.io.formats import acceptance as steps_format
    from accelcal.methods.acceptance import simulate

    rng = np.random.default_rng(seed)
    info = lab(date, serial)
    for test, settings in TESTS.items():
        rec = simulate(test, seed=rng, **settings)
        steps_format.write(data_dir / f"acceptance-{test}.csv",
                           dataclasses.replace(rec, metadata={**rec.metadata, **info}))
    return data_dir / "acceptance-threshold.csv"


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.methods.acceptance import reduce
    from accelcal.pipeline import Outcome

    outcomes = []
    for test in TESTS:
        file = path.with_name(f"acceptance-{test}.csv")
        red = reduce(file)
        outcomes.append(Outcome(red, red.to_records(lab_info([file]), input_files=[file]),
                                f"acceptance-{test}"))
    return outcomes
