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
