"""A certificate of a frequency response: points per frequency, the model, schema, DCC, figure."""

import base64
import json
import math
from dataclasses import replace
from types import SimpleNamespace

import pytest
from scipy.special import stdtrit

from accelcal.certificate import issue, schema
from accelcal.certificate.content import _method
from accelcal.certificate.dcc import DCC_NS, SI_NS
from accelcal.io.calibration_record import CalibrationRecord
from helpers.certificates import LAB, RESPONSE_SERIAL, RESPONSE_TRUTH, write_response_inputs

SPEC = """
title = "Frequency response, model QA-3000"
document = "SPEC-FR-7"

[[limit]]
quantity = "magnitude deviation"
lower = -3.0
upper = 3.0
unit = "%"
band_hz = [10, 400]

[[limit]]
quantity = "magnitude deviation"
lower = -10.0
upper = 10.0
unit = "%"
band_hz = [500, 1000]
"""
"""±3 % up to 400 Hz (the points there conform), ±10 % at 500-1000 Hz (800 Hz, -44 %, does not)."""


@pytest.fixture(scope="module")
def issued(tmp_path_factory):
    """The records, and their certificate issued once with JSON, XML and the specification."""
    d = tmp_path_factory.mktemp("response")
    paths = write_response_inputs(d)
    (d / "spec.toml").write_text(SPEC, encoding="utf-8")
    result = issue(paths, LAB, out=d / "c.html", json_out=d / "c.json", xml=d / "c.xml",
                   issued="2026-11-26", spec_path=d / "spec.toml", keep_budgets=True)
    return SimpleNamespace(dir=d, paths=paths, doc=result.document,
                           records=[CalibrationRecord.load(p) for p in paths])


def _item(doc):
    (item,) = doc["items"]
    return item


def _budget(doc, name):
    return next(b for b in doc["budgets"] if b["coefficient"] == name)


def test_points_carry_the_budgets_magnitude_and_phase(issued):
    item = _item(issued.doc)
    assert item["serial"] == RESPONSE_SERIAL
    (curve,) = item["response"]
    pol = issued.records[0].polar()
    assert [p["frequency_hz"] for p in curve["points"]] == [10, 40, 80, 160, 400, 800]
    assert curve["unit"] == "V/g"
    assert curve["reference_frequency_hz"] == 80
    # the reference's certificate: U = 0.5 % (k = 2; the lab's reliability 10 % -> 50 dof,
    # GUM G.4.2), u = 0.25 %; it dominates every magnitude, the reference phase (0.25 deg)
    # every phase; the comparison's other inputs (relative and transverse motion 0.058 and
    # 0.029 %, the channels' delay mismatch 0.36 mdeg/Hz, ...) and the data's own scatter
    # add up to 6 %
    k50 = float(stdtrit(50, 0.5 + 0.9545 / 2))
    for i, p in enumerate(curve["points"]):
        assert p["magnitude"] == pytest.approx(pol.magnitude[i], rel=1e-12)
        assert p["phase_deg"] == pytest.approx(math.degrees(pol.phase[i]), abs=1e-9)
        assert 0.0025 <= p["magnitude_u"] / p["magnitude"] < 0.0025 * 1.06
        assert p["magnitude_k"] == pytest.approx(k50, rel=5e-3)
        assert p["magnitude_U"] == pytest.approx(p["magnitude_k"] * p["magnitude_u"], rel=1e-9)
        assert 0.25 <= p["phase_u"] < 0.25 * 1.06
        assert p["phase_k"] == pytest.approx(2.0, rel=1e-3)
        budget = _budget(issued.doc, f"{p['coefficient']} magnitude")
        assert p["magnitude_U"] == pytest.approx(budget["U"] * p["magnitude"] / 100, rel=1e-12)


def test_deviation_leaves_out_the_inputs_common_to_every_step(issued):
    points = _item(issued.doc)["response"][0]["points"]
    ref = next(p for p in points if p["frequency_hz"] == 80)
    assert (ref["deviation_pct"], ref["deviation_u"]) == (0.0, 0.0)
    for p in points:
        ratio = p["magnitude"] / ref["magnitude"]
        assert p["deviation_pct"] == pytest.approx(100 * (ratio - 1), rel=1e-12, abs=1e-12)
        assert p["deviation_db"] == pytest.approx(20 * math.log10(ratio), rel=1e-12, abs=1e-12)
        if p is ref:
            continue
        # the two steps' budgets less the inputs of one coefficient at every step (the
        # reference's sensitivity, the channels' gain ratio, the DUT's temperature and its
        # coefficient: they cancel in the ratio), in quadrature, scaled by the ratio
        rows = [r for name in (p["coefficient"], ref["coefficient"])
                for r in _budget(issued.doc, f"{name} magnitude")["rows"]
                if r["quantity"] not in ("reference_sensitivity", "daq_gain_mismatch",
                                         "sensor_temperature", "sensitivity_tc")]
        expected = ratio * math.sqrt(sum(r["contribution"] ** 2 for r in rows))
        assert p["deviation_u"] == pytest.approx(expected, rel=1e-9)
        # below the 0.25 % of either magnitude: the relative and transverse motion of the
        # two steps, taken as independent, are most of it
        assert p["deviation_u"] < 0.15


def test_model_phase_and_group_delay_follow_the_closed_form(issued):
    item = _item(issued.doc)
    (model,) = item["response_models"]
    par = model["parameters"]
    for key, truth in RESPONSE_TRUTH.items():
        assert par[key] == pytest.approx(truth, rel=1e-3)
    results = {r["coefficient"]: r for r in item["results"]}
    assert list(results) == ["S0", "fn", "zeta", "f_3dB"]
    # S0 inherits every point's reference sensitivity (U = 0.5 %, k = 2): its U is at
    # least that, not the fit's own scatter (10 ppm)
    s0 = results["S0"]
    assert s0["U"] / s0["estimate"] >= 0.005
    s0_budget = next(b for b in issued.doc["budgets"] if b["coefficient"] == "S0")
    top = s0_budget["rows"][0]
    assert top["quantity"] == "reference_sensitivity"
    assert top["contribution"] / s0["estimate"] == pytest.approx(0.0025, rel=1e-4)
    (at,) = model["at"]  # default: the measured response's reference frequency
    assert at["frequency_hz"] == 80
    # second order: phi = -atan2(2 zeta wn w, wn^2 - w^2),
    # tau = 2 zeta wn (wn^2 + w^2) / ((wn^2 - w^2)^2 + (2 zeta wn w)^2) [Ogata2010 sec. 8-2]
    wn, z, w = 2 * math.pi * par["fn"], par["zeta"], 2 * math.pi * 80
    phase = -math.degrees(math.atan2(2 * z * wn * w, wn**2 - w**2))
    tau = 2 * z * wn * (wn**2 + w**2) / ((wn**2 - w**2) ** 2 + (2 * z * wn * w) ** 2)
    assert at["phase_deg"] == pytest.approx(phase, abs=1e-9)
    assert at["group_delay_s"] == pytest.approx(tau, rel=1e-6)
    assert at["phase_u"] == pytest.approx(0.25, rel=1e-3)  # the reference phase enters
    assert at["group_delay_U"] < 1e-2 * tau  # a common phase offset does not
    names = {b["coefficient"] for b in issued.doc["budgets"]}
    assert {"phase at 80 Hz", "group delay at 80 Hz"} <= names


def test_stated_frequencies_of_the_model(issued, tmp_path):
    result = issue(issued.paths[1:], LAB, out=tmp_path / "c.html", issued="2026-11-26",
                   phase_at=(100.0, 600.0))
    (model,) = _item(result.document)["response_models"]
    assert [a["frequency_hz"] for a in model["at"]] == [100.0, 600.0]
    assert model["at"][1]["phase_deg"] == pytest.approx(-90.0, abs=0.5)  # at fn
    assert "response" not in _item(result.document)


def test_response_certificate_is_valid_against_the_schema(issued):
    import jsonschema

    doc = json.loads((issued.dir / "c.json").read_text(encoding="utf-8"))
    assert doc == issued.doc
    validator = jsonschema.Draft202012Validator(schema(),
                                                format_checker=jsonschema.FormatChecker())
    assert list(validator.iter_errors(doc)) == []
    item = _item(doc)
    point = {k: v for k, v in item["response"][0]["points"][0].items() if k != "phase_U"}
    broken = dict(doc, items=[dict(item, response=[dict(item["response"][0],
                                                        points=[point])])])
    assert list(validator.iter_errors(broken))
    broken = dict(doc, items=[dict(item, response_models=[
        dict(item["response_models"][0], parameters={"S0": 1.3})])])
    assert list(validator.iter_errors(broken))


def test_conformity_per_point_inside_each_band(issued):
    points = _item(issued.doc)["response"][0]["points"]
    stated = [(p["frequency_hz"], p["conformity"]["outcome"] if p["conformity"] else None)
              for p in points]
    assert stated == [(10, "accept"), (40, "accept"), (80, "accept"), (160, "accept"),
                      (400, "accept"), (800, "reject")]
    worst = points[-1]["conformity"]
    assert (worst["lower"], worst["upper"], worst["unit"]) == (-10.0, 10.0, "%")
    assert worst["quantity"] == "magnitude deviation at 800 Hz"
    html = (issued.dir / "c.html").read_text(encoding="utf-8")
    assert html.count("magnitude deviation at ") == 6
    assert "does not conform" in html


def test_dcc_lists_the_quantities_per_frequency(issued):
    from lxml import etree

    root = etree.parse(str(issued.dir / "c.xml")).getroot()
    ns = {"dcc": DCC_NS, "si": SI_NS}
    (outer,) = root.xpath(".//dcc:list[@refType='accelcal_frequency_response']", namespaces=ns)
    per = outer.findall("dcc:list", ns)
    assert len(per) == 6
    units = [q.findtext("si:real/si:unit", namespaces=ns) for q in per[3].findall(
        "dcc:quantity", ns)]
    assert units == [r"\hertz", r"\volt\second\tothe{2}\metre\tothe{-1}", r"\percent",
                     r"\degree"]
    point = _item(issued.doc)["response"][0]["points"][3]
    value = float(per[3].xpath("dcc:quantity[@refType='accelcal_magnitude']/si:real/si:value",
                               namespaces=ns)[0].text)
    assert value == pytest.approx(point["magnitude"] / 9.80665, rel=1e-12)
    assert root.xpath(".//dcc:statement/dcc:conformity/text()", namespaces=ns) == [
        "pass"] * 5 + ["fail"]
    (model,) = root.xpath(".//dcc:list[@refType='accelcal_response_model']", namespaces=ns)
    assert model.xpath(".//si:unit/text()", namespaces=ns) == [r"\hertz", r"\degree",
                                                               r"\second"]


def test_dcc_of_a_response_keeps_the_schemas_structure(issued):
    from lxml import etree

    from helpers.dcc import CERT_UNITS, dsi_unit, violations

    root = etree.parse(str(issued.dir / "c.xml")).getroot()
    assert violations(root) == []
    ns = {"dcc": DCC_NS, "si": SI_NS}
    point = root.xpath(".//dcc:list[@refType='accelcal_response_point']", namespaces=ns)[0]
    assert [etree.QName(e).localname for e in point] == ["name"] + ["quantity"] * 4
    # the magnitude's D-SI unit is the certificate's V/g: same dimension, scale 1/g_n
    (unit,) = set(root.xpath(".//dcc:quantity[@refType='accelcal_magnitude']/si:real/si:unit/"
                             "text()", namespaces=ns))
    scale, dimension = dsi_unit(unit)
    assert dimension == CERT_UNITS["V/g"][1]
    assert scale / 9.80665 == pytest.approx(CERT_UNITS["V/g"][0], rel=1e-12)


def test_html_states_the_method_traceability_and_the_bode_figure(issued):
    html = (issued.dir / "c.html").read_text(encoding="utf-8")
    assert "Frequency response: comparison with a reference accelerometer" in html
    assert "ISO 16063-21" in html
    assert "REF-2025-311" in html  # the reference accelerometer's certificate
    assert "reference_sensitivity" in html
    assert "Group delay (ms)" in html
    start = html.index('src="data:image/svg+xml;base64,') + len('src="data:image/svg+xml;base64,')
    svg = base64.b64decode(html[start:html.index('"', start)]).decode()
    assert svg.lstrip().startswith("<?xml")
    assert "<dc:date>" not in svg  # no date: a reissue is identical
    assert svg.count("<path") > 50  # points, bands, the model, the text as paths


def test_response_certificate_reissue_is_byte_identical(issued, tmp_path):
    """Reissued from the budgets the records kept (``keep_budgets``), as a laboratory does."""
    assert all(r.budget is not None for r in issued.records)
    first = {n: (issued.dir / n).read_bytes() for n in ("c.html", "c.json", "c.xml")}
    issue(issued.paths, LAB, out=tmp_path / "c.html", json_out=tmp_path / "c.json",
          xml=tmp_path / "c.xml", issued="2026-11-26", spec_path=issued.dir / "spec.toml")
    for name, data in first.items():
        assert (tmp_path / name).read_bytes() == data, name


def test_each_route_names_its_standard():
    titles = {m: _method(SimpleNamespace(method=m)) for m in (
        "response/comparison", "response/laser", "response/gravity", "response/model-fit")}
    assert "ISO 16063-21" in titles["response/comparison"]["standard"]
    assert "ISO 16063-11" in titles["response/laser"]["standard"]
    assert "ISO 16063-16" in titles["response/gravity"]["standard"]
    assert "laser interferometry" in titles["response/laser"]["title"]


@pytest.mark.slow  # importing WeasyPrint alone takes 2-3 s
def test_pdf_of_a_response_certificate(issued, tmp_path):
    import pypdf

    from accelcal.certificate.render import pdf_available

    if not pdf_available():
        pytest.skip("WeasyPrint or its system libraries are not installed")
    issue(issued.paths, LAB, out=tmp_path / "c.html", pdf=tmp_path / "c.pdf",
          issued="2026-11-26")
    reader = pypdf.PdfReader(tmp_path / "c.pdf")
    n = len(reader.pages)
    texts = [p.extract_text() for p in reader.pages]
    # the results (a page or two with the figure), then the annex: 6 points' magnitude and
    # phase budgets and the fit's 4, each of the comparison's ~15 inputs, 2-3 to a page
    assert 3 <= n <= 14
    for i, text in enumerate(texts, 1):
        assert f"Page {i} of {n}" in text
    first = texts[0]
    assert "Frequency response: comparison" in first
    assert "Deviation (%)" in first
    assert "S0" in first
    assert "REF-2025-311" in "".join(texts[:2])
    assert "Annex" in "".join(texts)
    assert sum("/Image" in str(p.get("/Resources", {})) or "/XObject" in str(
        p.get("/Resources", {})) for p in reader.pages) >= 1  # the Bode figure is drawn


def test_without_lab_inputs_the_points_state_the_records_own_uncertainty(issued):
    from accelcal.budget.lab import load_lab
    from accelcal.certificate.content import build

    record = replace(CalibrationRecord.load(issued.paths[0]), budget=None)  # none kept
    doc = build([record], load_lab(LAB), issued="2026-11-26")
    pol = record.polar()
    k = float(stdtrit(record.dof, 0.5 + 0.9545 / 2)) if record.dof else 2.0
    for i, p in enumerate(_item(doc)["response"][0]["points"]):
        assert p["magnitude_u"] == pytest.approx(pol.magnitude_std[i], rel=1e-9)
        assert p["phase_u"] == pytest.approx(math.degrees(pol.phase_std[i]), rel=1e-9)
        assert p["magnitude_k"] == pytest.approx(k, rel=1e-6)


def test_other_records_certificates_carry_nothing_of_a_response(tmp_path):
    from helpers.certificates import write_inputs

    doc = issue(write_inputs(tmp_path), LAB, out=tmp_path / "c.html",
                issued="2026-11-26").document
    assert all(not ({"response", "response_models"} & set(i)) for i in doc["items"])
    html = (tmp_path / "c.html").read_text(encoding="utf-8")
    assert "<figure" not in html
    assert "Frequency response" not in html
    assert html.count("<h2>Results</h2>") == 2
