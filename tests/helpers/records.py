"""Calibration records made for the store tests (also imported by their subprocesses)."""

import datetime as dt

import numpy as np

from accelcal.io.calibration_record import CalibrationRecord
from accelcal.results import Estimate


def make_record(serial="SN-1", date="2026-01-01T00:00:00+00:00", shift=0.0,
                method="dividing-head/joint", **kwargs):
    """One indexing-head record (K_F, K_I, K_O with a diagonal covariance), offset by ``shift``."""
    est = Estimate(
        ("K_F", "K_I", "K_O"), np.array([-8.3e-4, 1.2993698, -1.2e-5]) + shift,
        np.diag([1.0e-12, 4.0e-12, 9.0e-12]), {"K_F": "V", "K_I": "V/g", "K_O": "V"},
        method, notes=("first harmonic known",),
    )
    return CalibrationRecord.from_estimate(est, serial=serial, date=date, **kwargs)


def records(n, serial="SN-1", start=0, methods=("dividing-head/joint",)):
    """``n`` distinct records of ``serial``, a day apart from day ``start``."""
    first = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
    return [make_record(serial=serial, method=methods[i % len(methods)], shift=i * 1e-7,
                        date=(first + dt.timedelta(days=start + i)).isoformat())
            for i in range(n)]
