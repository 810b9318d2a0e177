"""The report's summary row of a frequency response: |S(80 Hz)|, S0, fn and f_3dB with U."""

import pytest

from accelcal.io.calibration_record import CalibrationRecord
from accelcal.report.summary import summary_rows
from helpers.certificates import RESPONSE_SERIAL, write_response_inputs


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    return [CalibrationRecord.load(p)
            for p in write_response_inputs(tmp_path_factory.mktemp("response"))]


def _lines(row):
    return {line.coefficient: line for cell in row["cells"].values() for line in cell}


def test_summary_row_has_the_key_results_of_a_response(records):
    (row,) = summary_rows(records)
    assert row["serial"] == RESPONSE_SERIAL
    lines = _lines(row)
    assert set(lines) == {"S(80 Hz)", "S0", "fn", "f_3dB"}
    assert lines["S0"].estimate.endswith("V/g")
    assert lines["f_3dB"].estimate.endswith("Hz")


def test_a_magnitude_budget_in_percent_gives_the_summary_its_u(records):
    comparison = records[0]
    magnitude = float(abs(comparison.estimates[comparison.names.index("S(80 Hz)")]))
    budgets = {(RESPONSE_SERIAL, comparison.method): [
        {"coefficient": "S(80 Hz) magnitude", "unit": "%", "estimate": 0.0, "U": 0.5,
         "k": 2.5}]}
    (row,) = summary_rows(records, budgets)
    line = _lines(row)["S(80 Hz)"]
    value, unit = line.expanded.split(" (k=")[0].split()
    assert unit == "V/g"
    assert float(value) == pytest.approx(0.005 * magnitude, rel=0.02)  # 0.5 % of |S|
    assert "(k=2.5)" in line.expanded
