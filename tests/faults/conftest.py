"""Inputs of the fault tier, made once per session in process (small, seeded)."""

import pytest


def _accelcal(*args) -> None:
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    assert exc.value.code == 0, args


@pytest.fixture(scope="session")
def inputs(tmp_path_factory):
    """Recordings, a calibration, a compensation model and a calibration record."""
    d = tmp_path_factory.mktemp("inputs")
    _accelcal("triad", "simulate", "--out", d / "s.csv", "--seed", "1")
    _accelcal("triad", "calibrate", d / "s.csv", "--out", d / "cal.json", "--record",
              d / "rec.json", "--serial", "SN1", "--format", "json")
    _accelcal("triad", "simulate", "--out", d / "t.csv", "--seed", "2", "--dwell", "150")
    _accelcal("thermal", "simulate", "--out", d / "th.csv", "--seed", "1")
    _accelcal("thermal", "reduce", d / "th.csv", "--compensation", d / "comp.json",
              "--format", "json")
    _accelcal("noise", "simulate", "--out", d / "n.parquet", "--N", "1e-5", "--rate", "1000",
              "--duration", "400")
    return d
