"""The certificate's files: JSON against its schema, HTML, DCC XML, PDF, and Chromium."""

import json
import re

import pytest

from accelcal.certificate import Item, issue, schema, to_json
from accelcal.certificate.dcc import DCC_NS, SI_NS, to_dcc
from accelcal.certificate.render import pages, render_html
from helpers.certificates import LAB, write_inputs


def _issue(tmp_path, **kwargs):
    paths = write_inputs(tmp_path)
    return issue(paths, LAB, out=tmp_path / "c.html", issued="2026-11-26",
                 item=Item("Example", "QA-3000", "2026-11-18"), **kwargs)


def test_json_certificate_is_valid_against_its_published_schema(tmp_path):
    import jsonschema

    jsonschema.Draft202012Validator.check_schema(schema())
    result = _issue(tmp_path, json_out=tmp_path / "c.json")
    doc = json.loads((tmp_path / "c.json").read_text(encoding="utf-8"))
    assert doc == result.document
    validator = jsonschema.Draft202012Validator(schema(),
                                                format_checker=jsonschema.FormatChecker())
    assert list(validator.iter_errors(doc)) == []
    broken = dict(doc, issued="26.11.2026")
    assert any(e.path and e.path[0] == "issued" for e in validator.iter_errors(broken))
    broken = dict(doc, items=[dict(doc["items"][0], serial="")])
    assert list(validator.iter_errors(broken))


def test_reissue_is_byte_identical(tmp_path):
    first = _issue(tmp_path, json_out=tmp_path / "c.json", xml=tmp_path / "c.xml")
    html, js, xml = ((tmp_path / n).read_bytes() for n in ("c.html", "c.json", "c.xml"))
    second = _issue(tmp_path, json_out=tmp_path / "c.json", xml=tmp_path / "c.xml")
    assert first.document == second.document
    assert (tmp_path / "c.html").read_bytes() == html
    assert (tmp_path / "c.json").read_bytes() == js
    assert (tmp_path / "c.xml").read_bytes() == xml


def test_html_has_a_results_page_per_serial_then_the_annex(tmp_path):
    doc = _issue(tmp_path).document
    html = (tmp_path / "c.html").read_text(encoding="utf-8")
    assert [p["kind"] for p in pages(doc)] == ["results", "results", "annex", "annex"]
    assert html.count('<section class="page"') == 4
    for i in range(1, 5):
        assert f"Page {i} of 4" in html
    assert "-638.77" in html
    assert "µg" in html
    assert "µrad" in html
    assert doc["number"] in html
    assert "AG-2025-017" in html
    assert "2030-06-30" in html
    assert "Dr. A. Metrologist" in html
    assert "Example Navigation Systems Ltd" in html
    assert "counter(pages)" in html


def test_html_escapes_every_text(tmp_path):
    doc = _issue(tmp_path).document
    doc["customer"]["name"] = "<script>alert(1)</script>"
    doc["items"][0]["make"] = "A & B <i>"
    html = render_html(doc)
    assert "<script>alert" not in html
    assert "&lt;script&gt;" in html
    assert "A &amp; B &lt;i&gt;" in html


def test_expired_standards_are_stated_visibly(tmp_path):
    from helpers.certificates import expired_lab

    paths = write_inputs(tmp_path)
    issue(paths, expired_lab(tmp_path), out=tmp_path / "c.html", issued="2026-11-26",
          allow_expired=True)
    html = (tmp_path / "c.html").read_text(encoding="utf-8")
    assert html.count('class="warning">Issued with standard(s) past their due date') == 2
    assert "(expired)" in html


def test_dcc_export_has_the_structure_of_the_dcc_schema(tmp_path):
    from lxml import etree

    doc = _issue(tmp_path, country="DE").document
    root = etree.fromstring(to_dcc(doc).encode())
    ns = {"dcc": DCC_NS, "si": SI_NS}
    assert root.tag == f"{{{DCC_NS}}}digitalCalibrationCertificate"
    assert root.get("schemaVersion") == "3.3.0"
    admin = root.find("dcc:administrativeData", ns)
    assert [etree.QName(e).localname for e in admin] == [
        "dccSoftware", "coreData", "items", "calibrationLaboratory", "respPersons",
        "customer"]
    assert root.findtext(".//dcc:coreData/dcc:uniqueIdentifier", namespaces=ns) == doc["number"]
    assert root.findtext(".//dcc:coreData/dcc:countryCodeISO3166_1", namespaces=ns) == "DE"
    assert root.findtext(".//dcc:beginPerformanceDate", namespaces=ns) == "2026-11-20"
    assert root.findtext(".//dcc:endPerformanceDate", namespaces=ns) == "2026-11-21"
    serials = root.xpath(".//dcc:item//dcc:identification/dcc:value/text()", namespaces=ns)
    assert serials == ["SN-1", "SN-2"]
    results = root.findall(".//dcc:measurementResult", ns)
    assert len(results) == 2
    # K_F in ug -> micro m/s^2 (times g_n); K_O in urad; K_I in V/g has no D-SI form here
    reals = results[0].findall("dcc:results/dcc:result//si:real", ns)
    assert [r.findtext("si:unit", namespaces=ns) for r in reals] == [
        r"\micro\metre\second\tothe{-2}", r"\micro\radian"]
    value = float(reals[0].findtext("si:value", namespaces=ns))
    assert value == pytest.approx(-8.3e-4 / 1.2993698 * 1e6 * 9.80665, rel=1e-12)
    k = float(reals[0].findtext(
        "si:measurementUncertaintyUnivariate/si:expandedMU/si:coverageFactor", namespaces=ns))
    assert k == pytest.approx(2.0, abs=1e-3)
    texts = results[0].xpath("dcc:results/dcc:result/dcc:data/dcc:text//text()",
                             namespaces=ns)
    assert any("V/g" in t for t in texts)
    used = results[0].findall(".//dcc:measuringEquipment", ns)
    assert len(used) == len(doc["standards"])
    gravity = results[0].xpath(".//dcc:influenceCondition//si:value/text()", namespaces=ns)
    assert float(gravity[-1]) == pytest.approx(9.812617)


def test_dcc_conformity_statements(tmp_path):
    from lxml import etree

    from helpers.certificates import SPEC

    (tmp_path / "spec.toml").write_text(SPEC, encoding="utf-8")
    doc = _issue(tmp_path, spec_path=tmp_path / "spec.toml").document
    root = etree.fromstring(to_dcc(doc).encode())
    ns = {"dcc": DCC_NS}
    assert root.xpath(".//dcc:statement/dcc:conformity/text()", namespaces=ns) == [
        "pass", "fail", "pass", "pass"]


def test_json_text_is_stable_and_finite(tmp_path):
    doc = _issue(tmp_path).document
    text = to_json(doc)
    assert text.endswith("}\n")
    assert "NaN" not in text
    assert "Infinity" not in text
    assert json.loads(text) == doc


@pytest.mark.slow  # importing WeasyPrint alone takes 2-3 s
def test_pdf_pages_text_and_counters(tmp_path):
    import pypdf

    from accelcal.certificate.render import pdf_available

    if not pdf_available():
        pytest.skip("WeasyPrint or its system libraries are not installed")

    doc = _issue(tmp_path, pdf=tmp_path / "c.pdf").document
    reader = pypdf.PdfReader(tmp_path / "c.pdf")
    n = len(reader.pages)
    assert n == 4  # one page of results per serial, one annex page per serial
    texts = [p.extract_text() for p in reader.pages]
    for i, text in enumerate(texts, 1):
        assert f"Page {i} of {n}" in text
        assert doc["number"] in text
    assert "SN-1" in texts[0]
    assert "SN-2" in texts[1]
    assert "-638.77" in texts[0]
    assert "µg" in texts[0]
    assert "AG-2025-017" in texts[0]
    assert "Dr. A. Metrologist" in texts[0]
    assert "Annex" in texts[2]
    assert "Type A" in texts[2]
    assert not re.search(r"Page \d+ of \d+.*Page", texts[0], re.S)  # the HTML footers hide


def test_certificate_renders_in_headless_chromium(tmp_path, chromium):
    _issue(tmp_path)
    shot = tmp_path / "c.png"
    proc = chromium((tmp_path / "c.html").as_uri(), shot, "1000,1600", "--hide-scrollbars")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert shot.stat().st_size > 20_000
    assert [line for line in proc.stderr.splitlines() if "CONSOLE" in line] == []


@pytest.mark.slow
def test_chromium_prints_the_certificate(tmp_path, chromium):
    import pypdf

    _issue(tmp_path)
    out = tmp_path / "chromium.pdf"
    proc = chromium((tmp_path / "c.html").as_uri(), tmp_path / "unused.png", "1000,1600",
                    f"--print-to-pdf={out}", "--no-pdf-header-footer")
    assert proc.returncode == 0, proc.stderr[-2000:]
    text = "".join(p.extract_text() for p in pypdf.PdfReader(out).pages)
    assert "SN-1" in text
    assert "SN-2" in text
    assert "Annex" in text
