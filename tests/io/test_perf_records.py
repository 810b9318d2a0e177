"""Record files written by Arrow's CSV writer (issue 16): same layout, floats bit for bit."""

import json

import numpy as np
import pytest

from accelcal.io.records import MARKER, read_record, write_record


def _awkward_floats(n: int, seed: int) -> np.ndarray:
    """Doubles of every magnitude: normal, subnormal, signed zeros, extremes, short decimals."""
    rng = np.random.default_rng(seed)
    bits = rng.integers(0, 2**63 - 2**52, n, dtype=np.int64)  # below the inf/nan exponent
    x = bits.view(np.float64) * rng.choice([-1.0, 1.0], n)
    special = [0.0, -0.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
               0.1, 1 / 3, 14.999999999999998, 1e22, 1e-5, 123456789012345678.0]
    x[: len(special)] = special
    return x


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_floats_survive_write_and_read_bit_for_bit(tmp_path, suffix):
    cols = {"t": _awkward_floats(20_000, 1), "u": _awkward_floats(20_000, 2)}
    path = tmp_path / f"r{suffix}"
    write_record(path, "test", {"units": {"t": "s", "u": "V"}}, cols)
    _, back = read_record(path, "test")
    for name, values in cols.items():
        # compare the bit patterns: -0.0 and 0.0 differ, every last bit counts
        np.testing.assert_array_equal(back[name].view(np.int64), values.view(np.int64))


def test_csv_layout_is_marker_metadata_header_rows(tmp_path):
    path = tmp_path / "r.csv"
    write_record(path, "test", {"units": {"a": "s", "b": "g"}, "note": "x"},
                 {"a": np.array([0.0, 0.5]), "b": np.array([1e-5, -2.0])})
    lines = path.read_bytes().split(b"\n")
    assert lines[0] == MARKER.encode()
    assert lines[1].startswith(b"# ")
    assert json.loads(lines[1][2:]) == {"format_version": 1, "kind": "test",
                                        "units": {"a": "s", "b": "g"}, "note": "x"}
    assert lines[2] == b"a,b"  # no quotes
    assert lines[3:] == [b"0,0.00001", b"0.5,-2", b""]  # shortest round-trip text, LF
