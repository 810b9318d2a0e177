"""Each record kind's import layout, declared by its format module (``IMPORT``).

io/recordings/kinds.py reads the declarations and has no branch per kind;
these are the layouts ``accelcal import`` has always made, kind by kind.
"""

import importlib

import pytest

from accelcal.errors import AccelcalError
from accelcal.io.formats import KINDS, ImportLayout
from accelcal.io.recordings.kinds import declared, layout, validator


def test_every_kind_declares_its_layout_and_reader():
    for kind, path in KINDS.items():
        spec = importlib.import_module(path).IMPORT
        assert isinstance(spec, ImportLayout)
        assert declared(kind) is spec
        assert validator(kind).__name__ == spec.reader
    assert {k for k in KINDS if declared(k).time} == {"shaker", "vibrafuge", "triad", "steps",
                                                      "response"}
    assert {k for k in KINDS if declared(k).stream} == {"noise", "triad"}


def test_a_declaration_refuses_an_unknown_policy_or_metadatum():
    with pytest.raises(ValueError, match="outputs"):
        ImportLayout(outputs="volts")
    with pytest.raises(ValueError, match="states"):
        ImportLayout(states=("frequency_hz",))


def test_an_unknown_kind_is_refused_with_the_kinds():
    with pytest.raises(AccelcalError, match="not known; use one of centrifuge, dividing-head"):
        declared("ferris-wheel")


def test_shaker_gets_a_time_column_outputs_in_g_and_the_rate():
    got = layout("shaker", {"ref": "R", "u": "U"}, {"R": "mg", "U": "m/s^2"}, 1000.0)
    assert got.columns == {"t": None, "ref": "R", "u": "U"}
    assert got.units == {"ref": "g", "u": "g", "t": "s"}
    assert got.factors["ref"] == 1e-3
    assert abs(got.factors["u"] * 9.80665 - 1.0) < 1e-15
    assert list(got.metadata.items()) == [("output_unit", "g"), ("sample_rate_hz", 1000.0)]
    assert (got.restart, got.stream) == ("", False)


def test_vibrafuge_time_restarts_at_each_point():
    got = layout("vibrafuge", {"point": "P", "static": "S", "vibrating": "V"},
                 {"P": "-", "S": "V", "V": "V"}, 2000.0)
    assert got.restart == "point"
    assert next(iter(got.columns)) == "t"
    assert got.metadata == {"output_unit": "V", "sample_rate_hz": 2000.0}


def test_noise_keeps_its_unit_and_names_impose_nothing():
    got = layout("noise", {"acc": "A"}, {"A": "counts"}, 100.0)
    assert got.units == {"acc": "1"}
    assert list(got.metadata.items()) == [("rate", 100.0), ("unit", "counts")]
    assert got.stream
    assert "t" not in got.columns  # a noise record has no time column
    # a column named like a fixed one is still an output (no unit imposed)
    assert layout("noise", {"ref": "A"}, {"A": "V"}, 10.0).units == {"ref": "V"}


def test_triad_keeps_the_input_unit():
    cols = {"acc_x": "X", "acc_y": "Y", "acc_z": "Z"}
    got = layout("triad", cols, dict.fromkeys("XYZ", "counts"), 200.0)
    assert got.units == {"acc_x": "1", "acc_y": "1", "acc_z": "1", "t": "s"}
    assert list(got.metadata.items()) == [("rate", 200.0), ("input_unit", "counts")]
    assert layout("triad", cols, dict.fromkeys("XYZ", "m/s^2"), 1.0).units["acc_x"] == "m/s^2"


def test_dividing_head_states_its_sensors_and_angles_in_degrees():
    got = layout("dividing-head", {"angle_deg": "A", "s1": "X", "s2": "Y"},
                 {"A": "rad", "X": "mV", "Y": "mV"}, None)
    assert got.units == {"angle_deg": "deg", "s1": "mV", "s2": "mV"}
    assert abs(got.factors["angle_deg"] - 57.29577951308232) < 1e-12
    assert list(got.metadata.items()) == [("output_unit", "mV"), ("sensors", ["s1", "s2"])]


@pytest.mark.parametrize("kind", ["tumble", "thermal", "centrifuge"])
def test_static_kinds_state_only_the_output_unit(kind):
    got = layout(kind, {"angle": "A", "output": "O"}, {"A": "deg", "O": "mV"}, 50.0)
    assert got.metadata == {"output_unit": "mV"}
    assert "t" not in got.columns


def test_an_output_in_a_unit_the_kind_cannot_hold_is_refused():
    with pytest.raises(AccelcalError, match="outputs are in V, mV, mA, g"):
        layout("tumble", {"angle": "A", "output": "O"}, {"A": "deg", "O": "counts"}, None)
    with pytest.raises(AccelcalError, match="must be in deg"):
        layout("tumble", {"angle": "A", "output": "O"}, {"A": "V", "O": "V"}, None)
