"""Write the small example files of examples/data/ (deterministic).

Run from the repository root::

    python examples/make_data.py            # rewrites examples/data/
    python examples/make_data.py OUT_DIR    # writes them elsewhere

Files (every one simulated from the embedded default accelerometer, or
Dong2014 Table 1's sensors for the indexing head, with a fixed seed and a
fixed date, so the output is the same on every run):

- ``indexing_head.csv`` and ``indexing_head.parquet``: four sensors at mount
  phases 0/90/180/270 deg, 24 positions, head error uniform within
  ±2 arcsec plus Dong2014's measured first harmonic;
- ``shaker/``: one record per direction angle (0..330 deg by 30), 5 g at
  160 Hz, 4 periods at 2560 Hz;
- ``vibrafuge.csv``: overloads 1, 2, 4 g times amplitudes 5, 7, 9 g at 50 Hz,
  0.1 s records at 2000 Hz;
- ``model.json``: the default accelerometer's model file;
- ``calibration_record.json``: the calibration record of sensor U1 of
  ``indexing_head.csv`` (joint reduction).

Every record file carries the laboratory metadata ``serial``, ``operator``,
``date`` and ``local_gravity``.
"""

import sys
from pathlib import Path

import numpy as np

DATE = "2026-11-20T09:30:00+00:00"
OPERATOR = "J. Smith"
LOCAL_GRAVITY = 9.80122
SERIALS = ["ACC-0001", "ACC-0002", "ACC-0003", "ACC-0004"]


def _lab(serial) -> dict:
    return {"serial": serial, "operator": OPERATOR, "date": DATE, "local_gravity": LOCAL_GRAVITY,
            "simulated": True}


def make(directory) -> list[Path]:
    """Write the example files into ``directory``; return their paths."""
    from accelcal.calibration import lab_info
    from accelcal.defaults import default_model
    from accelcal.io.formats.dividing_head import read_head_record, write_head_record
    from accelcal.io.formats.shaker import write_records
    from accelcal.io.formats.vibrafuge import write_vibrafuge
    from accelcal.methods.dividing_head import HeadData, options_from_record, reduce
    from accelcal.methods.transverse import axial_sensitivity
    from accelcal.rigs import vibrafuge
    from accelcal.rigs.dividing_head import (
        DONG2014_FIRST_HARMONIC,
        DONG2014_NOISE_V,
        AngleErrorProfile,
        DividingHeadRig,
        dong2014_models,
        simulate,
    )
    from accelcal.rigs.shaker import ShakerRig
    from accelcal.units import ARCSEC

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    written = []

    models = dong2014_models(4)
    rig = DividingHeadRig.uniform(24, models, angle_error=AngleErrorProfile.uniform(2 * ARCSEC),
                                  first_harmonic=DONG2014_FIRST_HARMONIC, noise=DONG2014_NOISE_V)
    run = simulate(rig, np.random.default_rng(1))
    for name in ("indexing_head.csv", "indexing_head.parquet"):
        write_head_record(out / name, rig.positions, run.outputs, rig.mounts,
                          nominal_scale_factors=[m.K1 for m in models],
                          first_harmonic=DONG2014_FIRST_HARMONIC, first_harmonic_sd=5e-7,
                          lab=_lab(SERIALS))
        written.append(out / name)

    model = default_model()
    records = ShakerRig(amplitude=5.0, frequency=160.0, sample_rate=2560.0, periods=4.0
                        ).simulate(model, np.deg2rad(np.arange(0.0, 360.0, 30.0)),
                                   rng=np.random.default_rng(2))
    extra = {"axial_sensitivity": {d: axial_sensitivity(model, d) for d in ("eq20", "symmetric")},
             **_lab(SERIALS[0])}
    written += write_records(records, out / "shaker", extra=extra)

    b, a = (x.ravel() for x in np.meshgrid([1.0, 2.0, 4.0], [5.0, 7.0, 9.0], indexing="ij"))
    vib = vibrafuge.simulate(model, b, a, frequency=50.0, sample_rate=2000.0, duration=0.1,
                             rng=np.random.default_rng(3))
    write_vibrafuge(out / "vibrafuge.csv", vib, provenance=_lab(SERIALS[0]))
    written.append(out / "vibrafuge.csv")

    model.save(out / "model.json")
    written.append(out / "model.json")

    head = read_head_record(out / "indexing_head.csv")
    result = reduce(HeadData.from_record(head), "joint", **options_from_record(head, "joint"))
    info = lab_info([out / "indexing_head.csv"], sensors=4)
    record = result.to_records(info, input_files=[out / "indexing_head.csv"])[0]
    record.save(out / "calibration_record.json")
    written.append(out / "calibration_record.json")
    return written


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent / "data"
    for path in make(target):
        sys.stdout.write(f"wrote {path}\n")
