"""A shaker record with a gap in its time column is refused in one line (the directions share
one time axis and the sine fits need consecutive samples: no repair is offered)."""

import numpy as np

from accelcal.io.formats.shaker import read_records, write_records
from accelcal.methods import transverse as tr
from accelcal.rigs.shaker import ShakerRig
from helpers.cli import refused


def test_a_gap_in_a_shaker_record_is_refused(tmp_path, capsys):
    rec = ShakerRig(amplitude=2.0, periods=2.5).simulate(tr.GUANTANG_FIG4, np.deg2rad([30.0]))
    path = tmp_path / "one.csv"
    write_records(rec, path)
    assert len(read_records(path)) == 1  # consecutive samples: read
    lines = path.read_text().splitlines()
    del lines[103:106]  # header lines, then data rows 101-103 lost
    path.write_text("\n".join(lines) + "\n")
    refused(["transverse", "analyze", path], capsys, "jumps", "about 3 samples missing",
            "data row 101", "cut the recording at the gap")
