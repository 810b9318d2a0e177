"""``thermal compensate --scale``: the output column's numbers times the scale, in its unit.

Every command that reads a recording takes ``--unit`` and ``--scale``; here the scale applies
to the output column only (the temperature keeps its own unit and numbers).
"""

import numpy as np
import pytest

from accelcal.methods.thermal import Compensation
from helpers.cli import refused, run_cli

SMALL = ["--setpoints", "-30,0,30,60,15,-15", "--points", "12", "--dwell", "30",
         "--warmup", "1800"]


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    from accelcal.cli import main

    path = tmp_path_factory.mktemp("thermal") / "rec.csv"
    with pytest.raises(SystemExit) as exc:
        main(["thermal", "simulate", "--out", str(path), "--seed", "4", *SMALL])
    assert exc.value.code == 0
    return path


def test_compensate_scales_the_output_column(record, tmp_path, capsys):
    from accelcal.io.formats import thermal as thermal_format

    comp, out = tmp_path / "c.json", tmp_path / "out.csv"
    code, _, err = run_cli(["thermal", "reduce", record, "--order", "1", "--compensation",
                            comp], capsys)
    assert code == 0, err
    code, _, err = run_cli(["thermal", "compensate", record, "--model", comp, "--out", out,
                            "--allow-extrapolation", "--scale", "2"], capsys)
    assert code == 0, err
    rec = thermal_format.read(record)
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    a, _ = Compensation.load(comp).apply(2 * rec.output, rec.temperature,
                                         allow_extrapolation=True)
    np.testing.assert_allclose(data[:, 1], 2 * rec.output, rtol=1e-12, atol=0)
    np.testing.assert_allclose(data[:, 2], rec.temperature, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(data[:, 3], a, rtol=1e-12, atol=1e-15)
    refused(["thermal", "compensate", record, "--model", comp, "--out", out, "--scale", "0"],
            capsys, "scale")
