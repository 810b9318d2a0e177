"""The still recording's part of the demo campaign (:mod:`accelcal.demo`).

One hour at 100 Hz of a navigation-grade accelerometer at rest (``DEMO``:
N = 20 ug/sqrt(Hz), B = 5 ug, K = 0.2 ug/sqrt(s), in g units), written as a
Parquet noise record and reduced by the streamed IEEE 952 fit.

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C.
"""

from functools import partial
from pathlib import Path

DEMO = {"N": 20e-6, "B": 5e-6, "K": 0.2e-6, "Q": 0.0, "R": 0.0}
"""Coefficients simulated, in g units (N g*sqrt(s), B g, K g/sqrt(s))."""

RECORDING = {"rate": 100.0, "duration": 3600.0}
"""Sample rate (Hz) and length (s)."""


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the file's laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("still recording (noise)", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    import numpy as np

    from accelcal.io.formats.noise import write_blocks
    from accelcal.rigs.noise import simulate_blocks, truth_metadata

    sequence = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    value = int(sequence.generate_state(1)[0])  # an integer seed, written into the record
    path = data_dir / "still.parquet"
    meta = {**truth_metadata(**DEMO, bias=0.0, seed=value, b_range=None), **lab(date, serial)}
    write_blocks(path, simulate_blocks(**DEMO, **RECORDING, seed=value), rate=RECORDING["rate"],
                 unit="g", metadata=meta)
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.methods.noise.stream import stream_fit
    from accelcal.pipeline import Outcome

    red = stream_fit(path, terms=("N", "B", "K"))
    return [Outcome(red, red.to_records(lab_info([path]), input_files=[path]), "noise",
                    {"truth": DEMO})]
