"""The demo's lab file, printed budget and certificate (the indexing-head stage alone)."""

import json

import pytest

from accelcal.demo import certify, stages
from accelcal.pipeline import run_campaign


@pytest.mark.slow  # the budget engine re-runs the joint reduction per position: ~5 s of CPU
def test_demo_certifies_the_indexing_head_sensors(tmp_path):
    result = run_campaign(stages()[:1], tmp_path / "demo", seed=3, progress=False, title="t")
    cert = certify(result, pdf=False)
    assert cert.lab.read_text(encoding="utf-8").startswith("# A lab file")
    assert cert.budget.splitlines()[0].strip().startswith("ACC-0001 K_F")
    assert "u_c = " in cert.budget
    assert "local_gravity" in cert.budget
    doc = json.loads((tmp_path / "demo" / "certificate.json").read_text(encoding="utf-8"))
    assert doc["number"] == cert.number
    assert [i["serial"] for i in doc["items"]] == ["ACC-0001", "ACC-0002", "ACC-0003",
                                                    "ACC-0004"]
    assert all(i["simulated"] for i in doc["items"])
    assert {s["quantity"] for s in doc["standards"]} >= {"local_gravity", "head_angle"}
    assert (tmp_path / "demo" / "certificate.html").is_file()


def test_the_packaged_lab_file_is_the_example():
    from importlib.resources import files

    from helpers.paths import ROOT

    packaged = files("accelcal.certificate").joinpath("example_lab.toml").read_text("utf-8")
    assert packaged == (ROOT / "examples" / "lab.toml").read_text(encoding="utf-8")
