"""The demo's lab file, printed budget and certificate (the indexing-head stage alone)."""

import json

import pytest

from accelcal.demo import certify, head_budgets, stages
from accelcal.pipeline import run_campaign


@pytest.mark.slow  # a campaign of the indexing head, its report and certificate: ~4 s
def test_demo_certifies_the_indexing_head_sensors(tmp_path, monkeypatch):
    result = run_campaign(stages()[:1], tmp_path / "demo", seed=3, progress=False, title="t",
                          budgets=head_budgets)
    assert sorted(s for s, _ in result.budgets) == ["ACC-0001", "ACC-0002", "ACC-0003",
                                                    "ACC-0004"]
    html = result.report.read_text(encoding="utf-8")
    assert 'id="budgets"' in html  # the report states the budgets the certificate uses
    assert "head_angle" in html

    def made_again(*args, **kwargs):
        raise AssertionError("the budgets are made once, for the report")

    monkeypatch.setattr("accelcal.budget.budgets", made_again)
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


@pytest.mark.slow  # the indexing head's and the frequency response's stages, certified: ~8 s
def test_demo_certifies_the_frequency_response(tmp_path, monkeypatch):
    from accelcal.catalog import demo_methods
    from accelcal.demo import demo_budgets

    chosen = [s for s, m in zip(stages(), demo_methods(), strict=True)
              if m.family in ("dividing-head", "response")]
    result = run_campaign(chosen, tmp_path / "demo", seed=3, progress=False, title="t",
                          budgets=demo_budgets)
    assert ("ACC-0001", "response/comparison") in result.budgets
    assert ("ACC-0001", "response/model-fit") in result.budgets

    def made_again(*args, **kwargs):
        raise AssertionError("the budgets are made once, for the report")

    monkeypatch.setattr("accelcal.budget.budgets", made_again)
    certify(result, pdf=False)
    doc = json.loads((tmp_path / "demo" / "certificate.json").read_text(encoding="utf-8"))
    first = doc["items"][0]
    assert first["serial"] == "ACC-0001"
    assert [p["frequency_hz"] for p in first["response"][0]["points"]] == [
        10, 20, 40, 80, 160, 315, 500, 630, 800, 1000, 1250]
    assert [a["frequency_hz"] for a in first["response_models"][0]["at"]] == [80]
    assert {"K_I", "S0", "fn", "zeta", "f_3dB"} <= {r["coefficient"] for r in first["results"]}
    assert all("response" not in i for i in doc["items"][1:])
    assert "reference_sensitivity" in {s["quantity"] for s in doc["standards"]}
    html = (tmp_path / "demo" / "certificate.html").read_text(encoding="utf-8")
    assert html.count("data:image/svg+xml;base64,") == 1
