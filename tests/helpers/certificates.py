"""Inputs of the certificate tests: two records, the example lab file, a specification."""

import datetime as dt
from pathlib import Path

from helpers.paths import ROOT
from helpers.records import make_record

LAB = ROOT / "examples" / "lab.toml"
"""The example lab file (every standard due after 2029)."""

SPEC = """
title = "Acceptance specification, model QA-3000"
document = "SPEC-0042 rev B"

[[limit]]
quantity = "K_F"
lower = -1000
upper = 1000
unit = "ug"

[[limit]]
quantity = "K_O"
lower = -9.0
upper = 9.0
unit = "urad"
"""
"""Limits on the bias (µg) and the misalignment (µrad) of the records of :func:`write_inputs`."""


def write_inputs(directory: Path, *, date: str = "2026-11-20T10:00:00+00:00") -> list[Path]:
    """Two indexing-head records (SN-1, SN-2) in ``directory``; their paths."""
    paths = []
    for i, serial in enumerate(("SN-1", "SN-2")):
        day = dt.datetime.fromisoformat(date) + dt.timedelta(days=i)
        record = make_record(serial=serial, date=day.isoformat(), shift=i * 1e-6)
        path = directory / f"{serial}.json"
        record.save(path)
        paths.append(path)
    return paths


def expired_lab(directory: Path) -> Path:
    """The example lab file with the gravity survey and the DMM's certificate due in 2020."""
    text = (LAB.read_text(encoding="utf-8").replace("due = 2029-05-31", "due = 2020-05-31")
            .replace("due = 2030-06-30", "due = 2020-06-30"))
    path = directory / "expired-lab.toml"
    path.write_text(text, encoding="utf-8")
    return path


RESPONSE_SERIAL = "FR-1"
"""Serial number of :func:`write_response_inputs`' records."""

RESPONSE_TRUTH = {"S0": 1.3, "fn": 600.0, "zeta": 0.6}
"""The simulated DUT's transfer function (second order, V/g, Hz)."""


def write_response_inputs(directory: Path, *, frequencies=(10.0, 40.0, 80.0, 160.0, 400.0,
                                                            800.0)) -> list[Path]:
    """A stepped-sine response record (Parquet) reduced to its two calibration records.

    Six steps at 5 kHz, 10 periods each, 0.1 mV of noise; the comparison's record
    (complex ``S(f Hz)``) and the second-order fit's (``S0, fn, zeta, f_3dB``), in
    ``directory`` beside the data, so a certificate re-reduces them for its budgets.
    """
    from accelcal.io.formats.response import write
    from accelcal.methods.response import fit_model, reduce
    from accelcal.rigs.shaker_response import DutResponse, ResponseRig

    data = directory / "response.parquet"
    dut = DutResponse(S0=RESPONSE_TRUTH["S0"], fn_hz=RESPONSE_TRUTH["fn"],
                      zeta=RESPONSE_TRUTH["zeta"])
    rig = ResponseRig(frequencies=tuple(frequencies), sample_rate=5000.0, periods=10)
    write(data, rig.simulate(dut, seed=11, metadata={
        "serial": RESPONSE_SERIAL, "operator": "A. Tester",
        "date": "2026-11-20T10:00:00+00:00"}))
    from accelcal.calibration import lab_info

    info = lab_info([data])
    comparison = reduce(data)
    fit = fit_model(comparison)
    paths = []
    for name, red in (("comparison", comparison), ("fit", fit)):
        (record,) = red.to_records(info, input_files=[data])
        path = directory / f"{RESPONSE_SERIAL}-{name}.json"
        record.save(path)
        paths.append(path)
    return paths
