"""The certificate's content: number, results in the field's units, budgets, conformity, dates."""

import math

import pytest
from scipy.stats import norm

from accelcal.budget.lab import load_lab
from accelcal.certificate.content import (
    Item,
    build,
    certificate_number,
    engine_budgets,
    record_digest,
    with_budgets,
)
from accelcal.conformity import parse_spec
from accelcal.errors import AccelcalError
from accelcal.io.calibration_record import CalibrationRecord
from helpers.certificates import LAB, SPEC, expired_lab, write_inputs

SF1 = 1.2993698
"""SN-1's scale factor K_I, V/g (helpers.records.make_record)."""


def _records(tmp_path):
    return [CalibrationRecord.load(p) for p in write_inputs(tmp_path)]


def _spec():
    import tomllib

    return parse_spec(tomllib.loads(SPEC))


def _result(doc, serial, name):
    item = next(i for i in doc["items"] if i["serial"] == serial)
    return next(r for r in item["results"] if r["coefficient"] == name)


def test_number_is_derived_from_the_records_and_the_lab_file(tmp_path):
    records, lab = _records(tmp_path), load_lab(LAB)
    number = certificate_number(records, lab)
    assert number.startswith("AC-")
    assert len(number) == 15
    assert certificate_number(records[::-1], lab) == number
    assert certificate_number(records[:1], lab) != number
    other = tmp_path / "lab.toml"
    other.write_text(LAB.read_text(encoding="utf-8").replace("PO-2026-0412", "PO-1"),
                     encoding="utf-8")
    assert certificate_number(records, load_lab(other)) != number


def test_results_are_in_the_field_units_with_the_budget_k_and_u(tmp_path):
    doc = build(_records(tmp_path), load_lab(LAB), issued="2026-11-26",
                item=Item("Example", "QA-3000", "2026-11-18"))
    kf = _result(doc, "SN-1", "K_F")
    # Dong2014 eq. (5): the bias in g is K_F / K_I; u = 1e-6 V, no dof: normal, k = 2
    assert kf["engineering"][0]["unit"] == "ug"
    assert kf["engineering"][0]["estimate"] == pytest.approx(-8.3e-4 / SF1 * 1e6, rel=1e-12)
    assert kf["k"] == pytest.approx(2.0, abs=1e-3)
    assert kf["engineering"][0]["U"] == pytest.approx(kf["k"] * 1e-6 / SF1 * 1e6, rel=1e-9)
    ko = _result(doc, "SN-1", "K_O")
    assert [e["unit"] for e in ko["engineering"]] == ["urad", "arcsec"]
    page = doc["items"][0]
    assert (page["make"], page["model"], page["received"]) == ("Example", "QA-3000",
                                                               "2026-11-18")
    assert page["calibrated"] == ["2026-11-20"]
    assert page["methods"][0]["title"] == "indexing head"
    assert "Dong" in page["methods"][0]["standard"]
    assert doc["conditions"]["local_gravity"]["value"] == pytest.approx(9.812617)
    assert doc["signatory"]["name"] == "Dr. A. Metrologist"
    assert len(doc["budgets"]) == 6
    assert doc["number"] == certificate_number(_records(tmp_path), load_lab(LAB))


def test_dof_of_the_record_gives_a_student_t_coverage_factor(tmp_path):
    records = _records(tmp_path)
    records = [CalibrationRecord.from_json(r.to_json().replace('"dof": null', '"dof": 5'))
               for r in records]
    doc = build(records, load_lab(LAB), issued="2026-11-26")
    from scipy.stats import t

    assert _result(doc, "SN-1", "K_F")["k"] == pytest.approx(t.ppf(0.5 + 0.9545 / 2, 5),
                                                             rel=1e-9)
    assert _result(doc, "SN-1", "K_F")["nu_eff"] == pytest.approx(5.0)


def test_expired_standard_refuses_unless_allowed(tmp_path):
    records, lab = _records(tmp_path), load_lab(expired_lab(tmp_path))
    with pytest.raises(AccelcalError) as info:
        build(records, lab, issued="2026-11-26")
    message = str(info.value)
    assert "daq_gain" in message
    assert "DMM-2025-208" in message
    assert "--allow-expired" in message
    doc = build(records, lab, issued="2026-11-26", allow_expired=True)
    assert doc["expired_standards"] == ["local_gravity", "daq_gain", "daq_offset",
                                        "daq_linearity"]
    assert [s["expired"] for s in doc["standards"] if s["quantity"] == "daq_gain"] == [True]


def test_a_standard_due_after_the_calibration_date_is_not_expired(tmp_path):
    records = [CalibrationRecord.load(p)
               for p in write_inputs(tmp_path, date="2019-01-10T00:00:00+00:00")]
    doc = build(records, load_lab(expired_lab(tmp_path)), issued="2026-11-26")
    assert doc["expired_standards"] == []


@pytest.mark.parametrize("kwargs", [{"issued": "26/11/2026"}, {"number": "A B"},
                                    {"country": "Germany"},
                                    {"item": Item(received="yesterday")},
                                    {"issued": "2026-11-20"},
                                    {"item": Item(received="2026-11-21")}])
def test_bad_options_are_refused(tmp_path, kwargs):
    kwargs = {"issued": "2026-11-26", **kwargs}
    with pytest.raises(AccelcalError):
        build(_records(tmp_path), load_lab(LAB), **kwargs)


def test_simple_and_guarded_statements_with_the_specific_risk(tmp_path):
    records, lab = _records(tmp_path), load_lab(LAB)
    simple = build(records, lab, issued="2026-11-26", spec=_spec())
    assert simple["decision_rule"]["rule"] == "simple"
    kf = _result(simple, "SN-1", "K_F")["conformity"]
    assert (kf["outcome"], kf["statement"]) == ("accept", "conforms")
    ko = _result(simple, "SN-1", "K_O")["conformity"]
    estimate, u = -1.2e-5 / SF1 * 1e6, 3e-6 / SF1 * 1e6
    assert ko["outcome"] == "reject"
    assert ko["statement"] == "does not conform"
    # JCGM 106 9.3: the PDF's mass outside [-9, 9] urad (normal: the record gives no dof)
    outside = norm.cdf((-9.0 - estimate) / u) + norm.sf((9.0 - estimate) / u)
    assert ko["false_accept_risk"] == pytest.approx(outside, rel=1e-9)
    assert _result(simple, "SN-2", "K_O")["conformity"]["outcome"] == "accept"
    assert _result(simple, "SN-1", "K_I")["conformity"] is None
    guarded = build(records, lab, issued="2026-11-26", spec=_spec(), rule="guarded")
    ko2 = _result(guarded, "SN-2", "K_O")["conformity"]
    assert ko2["outcome"] == "inconclusive"
    assert ko2["guard"] == pytest.approx(ko2["U"], rel=1e-12)  # w = U by default
    assert ko2["acceptance"] == pytest.approx([-9.0 + ko2["guard"], 9.0 - ko2["guard"]])


def test_a_limit_in_a_unit_the_result_cannot_take_is_refused(tmp_path):
    import tomllib

    spec = parse_spec(tomllib.loads(SPEC.replace('unit = "ug"', 'unit = "m/s^2"')))
    doc = build(_records(tmp_path), load_lab(LAB), issued="2026-11-26", spec=spec)
    assert _result(doc, "SN-1", "K_F")["conformity"]["unit"] == "m/s^2"
    spec = parse_spec(tomllib.loads(
        '[[limit]]\nquantity = "K_I"\nlower = 0\nupper = 2\nunit = "mA/g"\n'))
    with pytest.raises(AccelcalError, match="K_I"):
        build(_records(tmp_path), load_lab(LAB), issued="2026-11-26", spec=spec)


def test_records_keep_their_budgets_and_are_certified_from_them(tmp_path):
    records, lab = _records(tmp_path), load_lab(LAB)
    paths = write_inputs(tmp_path)
    fresh = engine_budgets(paths, records, lab)
    kept = [with_budgets(r, lab, b) for r, b in zip(records, fresh, strict=True)]
    assert kept[0].budget["lab"] == {"sha256": lab.sha256, "path": "lab.toml",
                                     "name": lab.laboratory.name}
    assert [b["coefficient"] for b in kept[0].budget["budgets"]] == ["K_F", "K_I", "K_O"]
    assert kept[0].budget["standards"][0]["certificate"].startswith("AG-2025-017")
    again = CalibrationRecord.from_json(kept[0].to_json())
    assert again.budget == kept[0].budget
    assert with_budgets(again, lab, []) is again
    assert record_digest(again) == record_digest(records[0])
    # a kept budget is what the certificate states, whatever the reduction gives today
    edited = dict(again.budget)
    edited["budgets"] = [dict(b) for b in edited["budgets"]]
    edited["budgets"][0]["U"] = 1.0e-5
    from dataclasses import replace

    doc = build([replace(again, budget=edited), records[1]], lab, issued="2026-11-26")
    assert _result(doc, "SN-1", "K_F")["engineering"][0]["U"] == 1.0e-5
    assert doc["number"] == build(records, lab, issued="2026-11-26")["number"]


def test_a_record_without_a_budget_block_writes_as_before(tmp_path):
    from helpers.paths import FIXTURES

    text = (FIXTURES / "calibration_record_v1.json").read_text(encoding="utf-8")
    record = CalibrationRecord.from_json(text)
    assert record.budget is None
    assert "budget" not in record.to_dict()


_ENTRY = ('{"coefficient": "K_F", "estimate": 1.0, "unit": "V", "u_c": 1.0, "nu_eff": "inf", '
          '"k": 2.0, "U": %s, "rows": [%s]}')
_ROW = ('{"quantity": "Type A", "estimate": 1.0, "u": 1.0, "unit": "V", '
        '"distribution": "normal", "sensitivity": 1.0, "contribution": 1.0, "dof": %s, '
        '"share": 1.0}')


@pytest.mark.parametrize("block", [
    '{"lab": {}}', '[]',
    '{"lab": {"sha256": "x"}, "standards": [], "budgets": [{}]}',
    '{"lab": {"sha256": "x"}, "standards": [], "budgets": [%s]}' % (_ENTRY % ('"2"', "")),
    '{"lab": {"sha256": "x"}, "standards": [], "budgets": [%s]}' % (
        _ENTRY % ("2.0", _ROW % '"many"')),
])
def test_a_malformed_budget_block_is_refused(tmp_path, block):
    text = _records(tmp_path)[0].to_json()
    good = '{"lab": {"sha256": "x"}, "standards": [], "budgets": [%s]}' % (
        _ENTRY % ("2.0", _ROW % '"inf"'))
    assert CalibrationRecord.from_json(text.rstrip().rstrip("}") + f', "budget": {good}}}')
    bad = text.rstrip().rstrip("}") + f', "budget": {block}}}'
    with pytest.raises(AccelcalError, match="budget"):
        CalibrationRecord.from_json(bad)


def test_infinite_dof_is_written_as_inf(tmp_path):
    doc = build(_records(tmp_path), load_lab(LAB), issued="2026-11-26")
    assert _result(doc, "SN-1", "K_F")["nu_eff"] == "inf"
    assert all(not isinstance(b["nu_eff"], float) or math.isfinite(b["nu_eff"])
               for b in doc["budgets"])


def test_engine_budgets_state_the_lab_standards_that_enter(tmp_path):
    paths = write_inputs(tmp_path)
    records, lab = [CalibrationRecord.load(p) for p in paths], load_lab(LAB)
    fresh = engine_budgets(paths, records, lab)
    assert [b["coefficient"] for b in fresh[0]] == ["K_F", "K_I", "K_O"]
    doc = build(records, lab, issued="2026-11-26", budgets=fresh)
    # the input data are not at hand: of the lab's inputs only local gravity enters
    assert [s["quantity"] for s in doc["standards"]] == ["local_gravity"]
    kf = _result(doc, "SN-1", "K_F")
    assert kf["unit"] == "V"
    assert kf["estimate"] == pytest.approx(-8.3e-4)
    assert kf["engineering"][0]["unit"] == "ug"
    assert kf["engineering"][0]["estimate"] == pytest.approx(-8.3e-4 / SF1 * 1e6, rel=1e-9)
    # U in the record's unit: the budget's U over the ratio of its Type A row to the record's u
    assert kf["U"] == pytest.approx(kf["engineering"][0]["U"] * SF1 * 1e-6, rel=1e-9)
    ki = _result(doc, "SN-1", "K_I")
    assert ki["unit"] == "V/g"
    assert ki["engineering"] == []
    assert ki["relative"]["U"] == pytest.approx(ki["U"] / SF1 * 1e6, rel=1e-9)
    ko = _result(doc, "SN-1", "K_O")
    assert [e["unit"] for e in ko["engineering"]] == ["urad", "arcsec"]
    assert ko["engineering"][1]["estimate"] == pytest.approx(
        ko["engineering"][0]["estimate"] * 0.206264806, rel=1e-8)


def test_a_limit_guard_band_overrides_u(tmp_path):
    import tomllib

    spec = parse_spec(tomllib.loads(SPEC.replace('unit = "urad"', 'unit = "urad"\nguard = 1.0')))
    doc = build(_records(tmp_path), load_lab(LAB), issued="2026-11-26", spec=spec,
                rule="guarded")
    ko = _result(doc, "SN-2", "K_O")["conformity"]
    assert ko["guard"] == 1.0
    assert ko["acceptance"] == [-8.0, 8.0]
    assert ko["outcome"] == "inconclusive"  # -8.47 urad: in the guard band [-9, -8]


def test_an_expired_standard_the_method_does_not_take_does_not_refuse(tmp_path):
    text = LAB.read_text(encoding="utf-8").replace("due = 2029-04-30", "due = 2020-04-30")
    lab_path = tmp_path / "lab.toml"
    lab_path.write_text(text, encoding="utf-8")
    lab = load_lab(lab_path)
    assert [s.quantity for s in lab.expired()] == ["reference_sensitivity", "reference_phase"]
    doc = build(_records(tmp_path), lab, issued="2026-11-26")  # a shaker's, not the head's
    assert doc["expired_standards"] == []


def test_a_scale_factor_in_ppm_is_named_a_deviation_from_nominal():
    """A scale factor whose field unit is ppm is its deviation from the nominal value: the
    results row says so, and the value itself (V/g) is beside it."""
    from accelcal.certificate.render import _result_view

    row = {"coefficient": "K_I", "plain": "K_I", "method": "dividing-head/joint",
           "estimate": 1.299372, "u_c": 1.1e-5, "U": 2.2e-5, "unit": "V/g", "k": 2.0,
           "relative": None,
           "engineering": [{"estimate": 1.7, "u": 8.5, "U": 17.0, "unit": "ppm"}]}
    view = _result_view(row)
    assert view["name"] == "K_I, deviation from nominal"
    assert view["unit"] == "ppm"
    assert "V/g" in view["also"]
    bias = {**row, "coefficient": "K_F", "plain": "K_F", "unit": "V",
            "engineering": [{"estimate": -640.3, "u": 2.0, "U": 4.0, "unit": "ug"}]}
    assert _result_view(bias)["name"] == "K_F"
