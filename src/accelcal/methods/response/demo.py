"""The frequency response's part of the demo campaign (:mod:`accelcal.demo`).

The default accelerometer's force-rebalance loop (1.3 V/g, 600 Hz, zeta 0.6)
back to back with the default reference on a shaker: 11 steps from 10 Hz to
1.25 kHz at 1 g, 20 periods each at 20 kHz, 0.1 mV of noise on each
channel, written as a Parquet response record; reduced by the stepped-sine
comparison (the sensitivity at each step, |S(80 Hz)| among them) and the
second-order fit (S0, fn, zeta and the -3 dB bandwidth), one calibration
record each, so that the store's history follows the magnitude at the
reference frequency and the bandwidth.

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Vibration calibration by comparison to a
   reference transducer.
"""

from functools import partial
from pathlib import Path


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the file's laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("shaker frequency response", partial(_simulate, serial=serial, lab=lab),
                 _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    import numpy as np

    from accelcal.io.formats.response import write
    from accelcal.rigs.shaker_response import DutResponse, ResponseRig

    sequence = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    value = int(sequence.generate_state(1)[0])  # an integer seed, written into the record
    path = data_dir / "response.parquet"
    write(path, ResponseRig().simulate(DutResponse(), seed=value,
                                       metadata={"source": "accelcal demo", **lab(date, serial)}))
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.methods.response import fit_model, reduce
    from accelcal.pipeline import Outcome

    info = lab_info([path])
    red = reduce(path)
    fit = fit_model(red)  # second order
    return [Outcome(red, red.to_records(info, input_files=[path]), "response", {"fit": fit}),
            Outcome(fit, fit.to_records(info, input_files=[path]), "response-fit")]
