"""The DCC export's structure: element order, required elements, number formats, D-SI units.

The rules (:mod:`helpers.dcc`) restate what PTB's DCC schema (3.3.0) and the
D-SI schema (2.2.0) prescribe for the elements accelcal writes, so that the
tests hold the export to them without the schema files (docs/certificate.md).
"""

import copy

import pytest
from lxml import etree

from accelcal.certificate import Item, issue
from accelcal.certificate.dcc import (
    DSI_UNITS,
    RESPONSE_UNITS,
    SCHEMA_VERSION,
    to_dcc,
)
from helpers.certificates import LAB, SPEC, write_inputs
from helpers.dcc import CERT_UNITS, NS, dims, dsi_unit, local, violations


@pytest.fixture(scope="module")
def head(tmp_path_factory):
    """The two-serial indexing-head certificate (with statements of conformity) and its XML."""
    d = tmp_path_factory.mktemp("dcc")
    (d / "spec.toml").write_text(SPEC, encoding="utf-8")
    doc = issue(write_inputs(d), LAB, out=d / "c.html", issued="2026-11-26", country="DE",
                item=Item("Example", "QA-3000", "2026-11-18"), spec_path=d / "spec.toml").document
    return doc, etree.fromstring(to_dcc(doc).encode())


def test_the_rules_catch_what_the_schema_would_refuse(head):
    _, root = head
    assert violations(root) == []
    broken = copy.deepcopy(root)
    mr = broken.find(".//dcc:measurementResult", NS)
    mr.append(mr.find("dcc:name", NS))  # name after results
    real = broken.find(".//si:real", NS)
    real.remove(real.find("si:unit", NS))
    broken.find(".//si:coverageFactor", NS).text = "2e0"
    broken.find(".//dcc:respPersons", NS).clear()
    broken.set("schemaVersion", "3.2.1")
    found = "\n".join(violations(broken))
    for part in ("measurementResult: children", "real: lacks ['unit']", "si:coverageFactor",
                 "respPersons is empty", "schemaVersion 3.2.1"):
        assert part in found


def test_head_certificate_keeps_the_schemas_structure(head):
    _, root = head
    assert SCHEMA_VERSION == "3.3.0"
    admin = root.find("dcc:administrativeData", NS)
    assert [local(e) for e in admin] == [
        "dccSoftware", "coreData", "items", "calibrationLaboratory", "respPersons", "customer",
        "statements"]
    assert [local(e) for e in admin.find("dcc:coreData", NS)] == [
        "countryCodeISO3166_1", "usedLangCodeISO639_1", "mandatoryLangCodeISO639_1",
        "uniqueIdentifier", "receiptDate", "beginPerformanceDate", "endPerformanceDate",
        "performanceLocation", "issueDate"]
    assert root.findtext(".//dcc:issueDate", namespaces=NS) == "2026-11-26"
    for mr in root.findall(".//dcc:measurementResult", NS):
        assert [local(e) for e in mr] == ["name", "usedMethods", "measuringEquipments",
                                           "influenceConditions", "results"]
    (lab,) = root.findall(".//dcc:calibrationLaboratory/dcc:contact/dcc:location", NS)
    assert lab.findtext("dcc:countryCode", namespaces=NS) == "DE"
    # a result with its expanded uncertainty in D-SI 2.2's form, not the deprecated expandedUnc
    (k_f,) = root.xpath("(.//dcc:quantity[@refType='accelcal_K_F'])[1]/si:real", namespaces=NS)
    assert [local(e) for e in k_f] == ["label", "value", "unit",
                                        "measurementUncertaintyUnivariate"]
    mu = k_f.find("si:measurementUncertaintyUnivariate/si:expandedMU", NS)
    assert mu.findtext("si:coverageFactor", namespaces=NS) == "2.0000"
    assert mu.findtext("si:coverageProbability", namespaces=NS) == "0.9545"
    assert not root.findall(".//si:expandedUnc", NS)


def test_every_unit_written_is_a_d_si_unit(head):
    _, root = head
    units = set(root.xpath(".//si:unit/text()", namespaces=NS))
    assert r"\micro\metre\second\tothe{-2}" in units
    for unit in units:
        dsi_unit(unit)  # raises on a unit D-SI does not know
    with pytest.raises(ValueError, match="unknown unit"):
        dsi_unit(r"\micro\g")
    with pytest.raises(ValueError, match="stray text"):
        dsi_unit(r"\micro\metre/\second")


@pytest.mark.parametrize("table", [DSI_UNITS, RESPONSE_UNITS], ids=["results", "response"])
def test_unit_tables_keep_dimension_and_scale(table):
    for unit, (dsi, factor) in table.items():
        scale, dimension = dsi_unit(dsi)
        cert_scale, cert_dimension = CERT_UNITS[unit]
        assert dimension == dims((cert_dimension, 1)), unit
        # value_dsi = value * factor, so one certificate unit is factor D-SI units
        assert factor * scale == pytest.approx(cert_scale, rel=1e-12), unit


def test_sparse_lab_still_gives_every_required_element(head):
    doc, _ = head
    c = copy.deepcopy(doc)
    c.update(signatory=None, customer={}, standards=[])
    c["laboratory"].update(address="", country="", accreditation="  D-K  17 ")
    c["conditions"].update(environment={}, local_gravity=None)
    c["items"][0].update(model=" QA  3000 ")
    result = c["items"][0]["results"][0]
    result["engineering"] = [dict(result["engineering"][0], estimate=float("nan"),
                                  U=float("inf"))]
    root = etree.fromstring(to_dcc(c).encode())
    assert violations(root) == []
    assert root.findtext(".//dcc:respPerson/dcc:person/dcc:name/dcc:content",
                         namespaces=NS) == "No authorised signatory is named in the lab file"
    assert root.find(".//dcc:respPerson/dcc:mainSigner", NS) is None
    for contact in ("calibrationLaboratory/dcc:contact", "customer"):
        assert root.findtext(f".//dcc:{contact}/dcc:location/dcc:further/dcc:content",
                             namespaces=NS) == "not stated"
    assert root.find(".//dcc:influenceConditions", NS) is None
    assert root.find(".//dcc:measuringEquipments", NS) is None
    assert root.findtext(".//dcc:calibrationLaboratoryCode", namespaces=NS) == "D-K 17"
    assert root.findtext(".//dcc:item/dcc:model", namespaces=NS) == "QA 3000"
    assert root.findtext(".//dcc:countryCodeISO3166_1", namespaces=NS) == "ZZ"
    (k_f,) = root.xpath("(.//dcc:quantity[@refType='accelcal_K_F'])[1]/si:real", namespaces=NS)
    assert k_f.findtext("si:value", namespaces=NS) == "NaN"
    assert k_f.findtext(".//si:valueExpandedMU", namespaces=NS) == "NaN"
