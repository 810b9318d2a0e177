"""The vibrafuge's part of the demo campaign (:mod:`accelcal.demo`).

The default accelerometer at overloads 1, 2, 4 g times vibration amplitudes
5..10 g at 50 Hz, 1 s records at 5000 Hz; K2, K3, K0', K1' by weighted
least squares.

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021.
"""

from functools import partial
from pathlib import Path

import numpy as np

OVERLOADS = (1.0, 2.0, 4.0)
AMPLITUDES = (5.0, 6.0, 7.0, 8.0, 9.0, 10.0)
VIBRAFUGE = {"frequency": 50.0, "sample_rate": 5000.0, "duration": 1.0}


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the files' laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("vibrafuge grid", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    from accelcal.defaults import default_model
    from accelcal.io.formats.vibrafuge import write_vibrafuge
    from accelcal.rigs.vibrafuge import simulate

    model = default_model()
    b, a = (x.ravel() for x in np.meshgrid(OVERLOADS, AMPLITUDES, indexing="ij"))
    run = simulate(model, b, a, rng=np.random.default_rng(seed), **VIBRAFUGE)
    path = data_dir / "vibrafuge.csv"
    write_vibrafuge(path, run, provenance={"simulated_model": model.terms(),
                                           **lab(date, serial)})
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.io.formats.vibrafuge import read_vibrafuge
    from accelcal.methods.vre import PAPER_TERMS, identify, reduce_run
    from accelcal.pipeline import Outcome

    meas = reduce_run(read_vibrafuge(path))
    red = identify(meas.overload, meas.amplitude, meas.vre, meas.uncertainty,
                   direction=meas.direction, terms=PAPER_TERMS, assumptions=meas.assumptions())
    return [Outcome(red, red.to_records(lab_info([path]), input_files=[path]), "vibrafuge")]
