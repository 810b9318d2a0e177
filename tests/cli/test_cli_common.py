"""Value grids and output rendering shared by the commands."""

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from accelcal import AccelcalError
from accelcal.cli.common import _csv_per_cell, csv_text, parse_grid, render


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("1,2,4", [1.0, 2.0, 4.0]),
        ("5:10:1", [5.0, 6.0, 7.0, 8.0, 9.0, 10.0]),  # stop on the grid: included
        ("0:1:0.3", [0.0, 0.3, 0.6, 0.8999999999999999]),  # stop off the grid: excluded
        ("0:355:5", [5.0 * k for k in range(72)]),
        ("1:0:-0.5", [1.0, 0.5, 0.0]),
        ("-2, 0:1:1, 7", [-2.0, 0.0, 1.0, 7.0]),
        ("3:3:1", [3.0]),
        ("1e-3", [1e-3]),
    ],
)
def test_parse_grid(text, expected):
    assert parse_grid(text, "--x") == expected


@given(
    start=st.integers(-1000, 1000),
    count=st.integers(1, 200),
    step=st.sampled_from([0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 1e-3]),
)
def test_range_includes_stop_on_grid(start, count, step):
    stop = start + (count - 1) * step
    values = parse_grid(f"{start}:{stop!r}:{step}", "--x")
    assert len(values) == count
    assert values[0] == start
    # start + k*step is computed once, so the last value is within rounding of stop.
    assert values[-1] == pytest.approx(stop, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty"),
        ("1,,2", "empty item"),
        ("abc", "'abc' is not a number"),
        ("1:2", "not a range start:stop:step"),
        ("1:2:x", "not a range"),
        ("1:5:0", "zero step"),
        ("5:1:1", "is empty"),
        ("nan", "not finite"),
        ("1,inf", "not finite"),
    ],
)
def test_parse_grid_errors_name_the_option(text, message):
    with pytest.raises(AccelcalError, match=message) as info:
        parse_grid(text, "--amplitude")
    assert str(info.value).startswith("--amplitude: ")


def test_render_formats_keep_precision():
    rows = [{"a": 0.1 + 0.2, "b": "x"}, {"a": 1e-300, "b": "y"}]
    csv_text = render(rows, "csv")
    assert csv_text.splitlines() == ["a,b", "0.30000000000000004,x", "1e-300,y"]
    assert json.loads(render(rows, "json")) == rows
    assert "0.3" in render(rows, "table", title="T")
    with pytest.raises(AccelcalError, match="--format 'xml'"):
        render(rows, "xml")


def test_render_writes_undetermined_values_validly():
    rows = [{"a": float("nan"), "b": 1.0}]
    assert json.loads(render(rows, "json")) == [{"a": None, "b": 1.0}]
    assert render(rows, "csv").splitlines()[1] == "nan,1.0"
    assert "n/a" in render(rows, "table")


def test_csv_column_path_is_byte_identical_to_the_csv_module():
    # The column-wise fast path (plain floats, ints, strings) and the per-cell csv module
    # path must give the same bytes for every kind of cell, quoting included.
    import math

    import numpy as np

    rng = np.random.default_rng(3)
    floats = [float(x) for x in rng.normal(0, 1, 50) * 10.0 ** rng.integers(-20, 20, 50)]
    floats += [math.nan, math.inf, -math.inf, 0.0, -0.0, 1.0, 1e16, 1e-5, 123456789.0]
    n = len(floats)
    cases = [
        {"id": list(range(n)), "x": floats, "name": [f"K{i}" for i in range(n)]},
        {"a": floats, "b": [f"with,comma {i}" for i in range(n)]},  # quoted: csv module
        {"a": floats, "b": ['say "hi"'] * n},
        {"a": floats, "b": ["line\nbreak"] * n},
        {"a": floats, "b": [""] * n},
        {"a": floats, "b": [np.float64(v) for v in floats]},  # numpy scalars: per cell
        {"a": floats, "b": [True, False] * (n // 2) + [True] * (n % 2)},
        {"a": floats, "b": [None] * n},
        {"only": floats},
    ]
    for case in cases:
        columns = list(case)
        rows = [dict(zip(columns, values, strict=True)) for values in zip(*case.values(),
                                                                         strict=True)]
        cells = ([r[c] for c in columns] for r in rows)
        assert render(rows, "csv") == _csv_per_cell(columns, cells), columns
        assert csv_text(case) == render(rows, "csv"), columns
    assert render([], "csv") == _csv_per_cell([], [])


def test_plain_columns_take_the_column_path(monkeypatch):
    from accelcal.cli import common

    def no_csv_module(*args, **kwargs):
        raise AssertionError("the per-cell csv module path was taken")

    monkeypatch.setattr(common.csv, "writer", no_csv_module)
    rows = [{"id": i, "date": "2020-01-01", "estimate": i / 7, "std": float("nan")}
            for i in range(5)]
    assert render(rows, "csv").splitlines()[1] == "0,2020-01-01,0.0,nan"
