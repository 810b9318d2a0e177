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
  ``indexing_head.csv`` (joint reduction);
- ``triad.csv``: a triad (serial IMU-0001) in counts on the six Ferraris
  positions at 50 Hz, 5 s still, 2 s per position;
- ``triad_calibration.json``: its calibration by known orientations;
- ``still.csv``: a still recording (noise kind) of ACC-0001, 60 s at 100 Hz,
  white noise 20 ug/sqrt(Hz) and bias instability 5 ug;
- ``thermal.csv``: a thermal-chamber test of ACC-0001 (8 plateaus, 12-point
  tumbles, 30 s per position) and ``thermal_compensation.json``, its
  second-order compensation model.

Every record file carries the laboratory metadata ``serial``, ``operator``,
``date`` and ``local_gravity``.
"""

import dataclasses
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
    written += _triad(out)
    written.append(_still(out))
    written += _thermal(out)
    return written


def _thermal(out: Path) -> list[Path]:
    """A thermal-chamber record and its compensation model (order 2)."""
    from accelcal.defaults import default_model
    from accelcal.io.formats import thermal
    from accelcal.methods.thermal import Compensation, reduce_thermal
    from accelcal.rigs.thermal import DEFAULT_TEMPERATURE, Programme, simulate

    model = default_model().replace(temperature=DEFAULT_TEMPERATURE)
    rec = simulate(model, Programme(points=12, dwell=30.0, warmup=600.0), seed=0)
    rec = dataclasses.replace(rec, metadata={**rec.metadata, **_lab(SERIALS[0])})
    thermal.write(out / "thermal.csv", rec)
    red = reduce_thermal(thermal.read(out / "thermal.csv"), order=2)
    comp = out / "thermal_compensation.json"
    Compensation.from_model(red.models[0], description="from thermal.csv").save(comp)
    return [out / "thermal.csv", comp]


def _still(out: Path) -> Path:
    """A short still recording (record kind noise)."""
    from accelcal.io.formats import noise
    from accelcal.rigs.noise import simulate

    rec = simulate(N=2e-5, B=5e-6, rate=100.0, duration=60.0, seed=5)
    rec = type(rec)(rec.values, rec.rate, rec.unit, rec.channels,
                    {**rec.metadata, **_lab(SERIALS[0])})
    noise.write(out / "still.csv", rec)
    return out / "still.csv"


def _triad(out: Path) -> list[Path]:
    """A six-position triad record and its known-orientation calibration."""
    from accelcal.io.formats import triad as triad_format
    from accelcal.methods.triad import TriadCalibration, calibrate_known, calibration_of
    from accelcal.rigs.triad import simulate, six_positions

    truth = TriadCalibration(bias=(120.0, -85.0, 40.0), scale=(4.79e-3, 4.81e-3, 4.78e-3),
                             angles=(1.2e-3, -0.8e-3, 2.1e-3), input_unit="counts")
    rec = simulate(truth, six_positions(), rate=50.0, dwell=2.0, motion=1.0, still=5.0,
                   noise_sd=2.0, seed=4, gravity=LOCAL_GRAVITY)
    rec = type(rec)(rec.t, rec.acc, rec.input_unit, rec.positions,
                    {**rec.metadata, **_lab("IMU-0001")})
    triad_format.write(out / "triad.csv", rec)
    spans = [(p["start"], p["stop"]) for p in rec.positions]
    means = np.array([rec.acc[a:b].mean(axis=0) for a, b in spans])
    red = calibrate_known(means, [p["up"] for p in rec.positions], LOCAL_GRAVITY,
                          input_unit="counts", counts=[b - a for a, b in spans])
    calibration_of(red).save(out / "triad_calibration.json")
    return [out / "triad.csv", out / "triad_calibration.json"]


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent / "data"
    for path in make(target):
        sys.stdout.write(f"wrote {path}\n")
