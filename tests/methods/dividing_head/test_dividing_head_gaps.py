"""A dividing-head record has no time column: its gap is a repeat that misses positions.
Refused by default with the hint, left out with --gaps split (noted, in the provenance),
never filled."""

import json

import numpy as np
import pytest

from accelcal.io.formats.dividing_head import read_head_record
from accelcal.methods.dividing_head import reduce
from helpers.cli import refused, run_cli
from helpers.paths import EXAMPLES


@pytest.fixture(scope="module")
def repeats(tmp_path_factory):
    """The example record read three times; the third repeat lacks one position."""
    lines = (EXAMPLES / "indexing_head.csv").read_text().splitlines()
    meta = json.loads(lines[1][2:])
    meta["units"]["repeat"] = "1"
    head, rows = lines[2].split(","), [r.split(",") for r in lines[3:]]
    out = [lines[0], "# " + json.dumps(meta), ",".join([head[0], "repeat", *head[1:]])]
    rng = np.random.default_rng(3)
    for r in range(3):
        for k, row in enumerate(rows):
            if r == 2 and k == 5:
                continue  # the missing reading
            noisy = [repr(float(v) + (1e-7 * rng.normal() if r else 0.0)) for v in row[1:]]
            out.append(",".join([row[0], str(r), *noisy]))
    path = tmp_path_factory.mktemp("head") / "repeats.csv"
    path.write_text("\n".join(out) + "\n")
    return path, 2 * len(rows) + 1  # the first data row of the incomplete repeat


def test_an_incomplete_repeat_is_refused_with_the_hint(repeats, capsys):
    path, _ = repeats
    refused(["dividing-head", "reduce", path], capsys, "repeat 2 does not cover the same",
            "(1 missing)", "--gaps split")
    refused(["dividing-head", "reduce", path, "--gaps", "fill"], capsys, "repeat 2",
            "never filled")


def test_split_leaves_the_incomplete_repeat_out(repeats, capsys):
    path, row = repeats
    code, out, err = run_cli(["dividing-head", "reduce", path, "--method", "four",
                              "--gaps", "split", "--format", "json"], capsys)
    assert code == 0, err
    assert (f"note: 1 incomplete repeats (positions missing) (data rows {row}): left out "
            "(split)") in err
    record = read_head_record(path, gaps="split")
    assert record.outputs.shape[0] == 2  # repeats 0 and 1 kept
    red = reduce(path, "four", gaps="split")
    assert red.provenance["repairs"]["found"][0]["first_rows"] == [row]
    rows = {r["coefficient"]: r["estimate"] for r in json.loads(out)}
    assert rows == pytest.approx({r["coefficient"]: r["estimate"] for r in red.rows()})
