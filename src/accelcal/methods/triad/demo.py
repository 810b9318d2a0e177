"""The triad's part of the demo campaign (:mod:`accelcal.demo`).

A triad with 16-bit-like raw outputs (counts: offsets of a few hundred
counts, about 1670 counts per m/s^2, non-orthogonality of a few mrad) is
turned through 18 positions (the six axis directions, then 12 random
ones), 5 s each at 100 Hz after a 30 s still period, and calibrated by both
routes: the gravity norm from the static intervals detected in the signal
(orientations unknown), and known orientations from the record's positions
(all 18 directions known, as on an indexing head).

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014.
.. [Ferraris1995] Ferraris F. et al., Sensors and Materials 7(5), 1995.
"""

from functools import partial
from pathlib import Path

import numpy as np

TRUE = {"bias": (310.0, -245.0, 120.0), "scale": (5.98e-4, 6.02e-4, 5.95e-4),
        "angles": (2.1e-3, -1.3e-3, 0.8e-3)}
"""The simulated triad: bias (counts), scale ((m/s^2)/count), angles (rad)."""

NOISE_COUNTS = 4.0
"""White noise per sample and axis, counts."""

STILL_S = 30.0
"""The still period at the start of the recording, s (the rig's default)."""


def stage(serial: str, lab):
    """The campaign stage: ``lab(date, serial)`` gives the files' laboratory metadata."""
    from accelcal.pipeline import Stage

    return Stage("accelerometer triad", partial(_simulate, serial=serial, lab=lab), _reduce)


def _simulate(data_dir: Path, date: str, seed, *, serial, lab) -> Path:
    from accelcal.io.formats import triad as triad_format
    from accelcal.methods.triad.model import TriadCalibration
    from accelcal.rigs.triad import random_directions, simulate, six_positions

    rng = np.random.default_rng(seed)
    info = lab(date, serial)
    up = np.vstack([six_positions(), random_directions(12, rng)])
    cal = TriadCalibration(**TRUE, input_unit="counts")
    rec = simulate(cal, up, noise_sd=NOISE_COUNTS, seed=rng, gravity=info["local_gravity"])
    rec = type(rec)(rec.t, rec.acc, rec.input_unit, rec.positions, {**rec.metadata, **info})
    path = data_dir / "triad.csv"
    triad_format.write(path, rec)
    return path


def _reduce(path: Path) -> list:
    from accelcal.calibration import lab_info
    from accelcal.io.formats import triad as triad_format
    from accelcal.methods.triad import calibrate_known, calibrate_unknown
    from accelcal.pipeline import Outcome
    from accelcal.signal.static import detect_static

    rec = triad_format.read(path)
    g = rec.metadata["gravity"]
    info = lab_info([path])
    # the gravity norm from the static intervals detected in the signal (as a lab's
    # recording without positions is reduced); known orientations from the record's positions
    found = detect_static(rec.acc, rec.metadata["rate"], init_static=STILL_S,
                          unit=rec.input_unit)
    norm = calibrate_unknown(found.means, g, input_unit=rec.input_unit, counts=found.counts,
                             labels=[f"I{k + 1}" for k in range(len(found))])
    means, counts = rec.interval_means()
    known = calibrate_known(means, rec.up, g, input_unit=rec.input_unit, labels=rec.labels,
                            counts=counts)
    return [Outcome(norm, norm.to_records(info, input_files=[path]), "triad-norm",
                    {"intervals": found, "values": rec.acc, "time": rec.t}),
            Outcome(known, known.to_records(info, input_files=[path]), "triad-known")]
