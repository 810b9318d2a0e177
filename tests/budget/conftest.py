"""Fixtures of the budget tests: a lab-file writer and a simulated tumble record."""

import pytest


@pytest.fixture
def write_lab(tmp_path):
    """``write_lab(text) -> path`` of a lab file in a temporary directory."""

    def write(text: str, name: str = "lab.toml"):
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write


@pytest.fixture(scope="session")
def tumble_file(tmp_path_factory):
    """A simulated 12-position tumble record file of the default accelerometer."""
    from accelcal.defaults import default_model
    from accelcal.io.formats import tumble as tumble_format
    from accelcal.rigs.tumble import simulate, uniform_positions

    path = tmp_path_factory.mktemp("budget") / "tumble.csv"
    record = simulate(uniform_positions(12, 0.0), default_model(), rotation_axis="OA", seed=4)
    tumble_format.write(path, record)
    return path
