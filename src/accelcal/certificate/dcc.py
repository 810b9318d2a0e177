r"""The certificate as a Digital Calibration Certificate (DCC, PTB's XML schema, version 3).

:func:`to_dcc` writes the certificate document (:mod:`accelcal.certificate.content`)
in the structure of PTB's DCC schema, version 3.2 [DCC]_: ``administrativeData``
(``dccSoftware``, ``coreData`` with the unique identifier and the
performance dates, ``items``, ``calibrationLaboratory``, ``respPersons``,
``customer``, ``statements`` with the conformity statements) and
``measurementResults`` with one ``measurementResult`` per serial number:
``usedMethods``, ``measuringEquipments`` (the standards, with their
certificates and due dates), ``influenceConditions`` (temperature, local
gravity) and ``results``, each a ``quantity`` holding an ``si:real``
(value, unit, expanded uncertainty with k and the coverage probability) in
D-SI notation [DSI]_. A frequency response is one ``result`` whose data are a
``dcc:list`` holding one ``dcc:list`` of quantities per frequency: the
frequency, the magnitude with U (per m/s² in D-SI, its output unit per g in
the name), the deviation from the reference frequency (%) and the phase
(degrees) with U; a fitted model's phase and group delay at stated
frequencies likewise (:data:`RESPONSE_UNITS`).

The country code is the laboratory's (``--country``), ``ZZ`` (ISO 3166's
code for an unknown country) when it is not stated.

D-SI has SI units only: a result in µg is written in ``\\micro\\metre
\\second\\tothe{-2}`` (times g_n = 9.806 65 m/s²), in ppm as ``\\ppm``, in
µrad as ``\\micro\\radian``, in µg/g² as ``\\micro\\second\\tothe{2}\\metre
\\tothe{-1}`` (divided by g_n), and so on (:data:`DSI_UNITS`); the
certificate's own unit is kept as the quantity's name. A result whose unit
has no D-SI form here (an output unit, V/g) is written in its record's unit
as ``dcc:text``.

The export is not validated against PTB's ``dcc.xsd`` in this package's
tests: the schema (LGPL-3.0, redistributable) is not distributed with any
package that the build can install (the Python libraries that handle DCCs
download it from PTB at run time), and the test machines reach no other
site; docs/certificate.md says what a laboratory does to validate it.

References
----------
.. [DCC] Physikalisch-Technische Bundesanstalt, Digital Calibration Certificate
   (DCC), XML schema ``dcc.xsd`` version 3.2, https://ptb.de/dcc/.
.. [DSI] Hutzschenreuter D. et al., SmartCom Digital System of Units (D-SI),
   version 2, PTB, 2020.
"""

import xml.etree.ElementTree as ET

from accelcal.units import STANDARD_GRAVITY

DCC_NS = "https://ptb.de/dcc"
SI_NS = "https://ptb.de/si"
SCHEMA_VERSION = "3.2.1"

_G = STANDARD_GRAVITY
DSI_UNITS = {
    "ug": (r"\micro\metre\second\tothe{-2}", _G),
    "mg": (r"\milli\metre\second\tothe{-2}", _G),
    "g": (r"\metre\second\tothe{-2}", _G),
    "m/s^2": (r"\metre\second\tothe{-2}", 1.0),
    "ppm": (r"\ppm", 1.0),
    "urad": (r"\micro\radian", 1.0),
    "arcsec": (r"\micro\radian", 4.84813681109536),
    "mg/g": (r"\one", 1e-3),
    "ug/g^2": (r"\micro\second\tothe{2}\metre\tothe{-1}", 1.0 / _G),
    "ug/g^3": (r"\micro\second\tothe{4}\metre\tothe{-2}", 1.0 / _G**2),
    "ug/g^4": (r"\micro\second\tothe{6}\metre\tothe{-3}", 1.0 / _G**3),
    "ug/degC": (r"\micro\metre\second\tothe{-2}\kelvin\tothe{-1}", _G),
    "ppm/degC": (r"\ppm\kelvin\tothe{-1}", 1.0),
    "urad/degC": (r"\micro\radian\kelvin\tothe{-1}", 1.0),
    "1": (r"\one", 1.0),
    "g/g": (r"\one", 1.0),
}
"""Certificate unit -> (D-SI unit, factor from the certificate's value to the D-SI one)."""

RESPONSE_UNITS = {
    "V/g": (r"\volt\second\tothe{2}\metre\tothe{-1}", 1.0 / _G),
    "mV/g": (r"\milli\volt\second\tothe{2}\metre\tothe{-1}", 1.0 / _G),
    "mA/g": (r"\milli\ampere\second\tothe{2}\metre\tothe{-1}", 1.0 / _G),
    "Hz": (r"\hertz", 1.0),
    "%": (r"\percent", 1.0),
    "deg": (r"\degree", 1.0),
    "s": (r"\second", 1.0),
}
"""A frequency response's units -> (D-SI unit, factor): the magnitude in output unit per g
is written per m/s² (divided by g_n)."""


def _q(ns: str, tag: str) -> str:
    return f"{{{ns}}}{tag}"


def _el(parent, tag: str, text=None, ns: str = DCC_NS, **attrib):
    e = ET.SubElement(parent, _q(ns, tag), attrib)
    if text is not None:
        e.text = str(text)
    return e


def _text(parent, tag: str, text: str):
    """A ``dcc:textBlock``: ``<tag><dcc:content lang="en">text</dcc:content></tag>``."""
    block = _el(parent, tag)
    _el(block, "content", text, lang="en")
    return block


def _real(parent, value: float, unit: str, expanded: float | None = None, *, k: float = 2.0,
          probability: float = 0.9545, label: str | None = None):
    """An ``si:real``: value and D-SI unit, with its expanded uncertainty when given."""
    real = _el(parent, "real", ns=SI_NS)
    if label:
        _el(real, "label", label, ns=SI_NS)
    _el(real, "value", repr(float(value)), ns=SI_NS)
    _el(real, "unit", unit, ns=SI_NS)
    if expanded is not None:
        unc = _el(real, "expandedUnc", ns=SI_NS)
        _el(unc, "uncertainty", repr(float(expanded)), ns=SI_NS)
        _el(unc, "coverageFactor", repr(round(float(k), 4)), ns=SI_NS)
        _el(unc, "coverageProbability", repr(probability), ns=SI_NS)
    return real


def _contact(parent, tag: str, name: str, address: str = ""):
    contact = _el(parent, tag)
    _text(contact, "name", name or "not stated")
    if address:
        _text(_el(contact, "location"), "further", address)
    return contact


def _result(results, r: dict, probability: float) -> None:
    result = _el(results, "result")
    _text(result, "name", f"{r['plain']} ({r['method']})")
    data = _el(result, "data")
    chosen = next(((e["estimate"], e["U"], e["unit"]) for e in r["engineering"]
                   if e["unit"] in DSI_UNITS), None)
    if chosen is None and r["unit"] in DSI_UNITS:
        chosen = (r["estimate"], r["U"], r["unit"])
    if chosen is None:
        _text(data, "text", f"{r['estimate']!r} {r['unit']}, U = {r['U']!r} {r['unit']} "
                            f"(k = {r['k']:.4f})")
        return
    value, big_u, unit = chosen
    dsi, factor = DSI_UNITS[unit]
    quantity = _el(data, "quantity", refType="accelcal_" + r["plain"])
    _text(quantity, "name", f"{r['plain']} in {unit}")
    _real(quantity, value * factor, dsi, big_u * factor, k=r["k"], probability=probability,
          label=r["coefficient"])


def _quantity(parent, name: str, ref: str, value: float, unit: str, *, expanded=None,
              k: float = 2.0, probability: float = 0.9545, label=None) -> None:
    """A ``dcc:quantity`` of a frequency response (:data:`RESPONSE_UNITS`)."""
    dsi, factor = RESPONSE_UNITS[unit]
    quantity = _el(parent, "quantity", refType="accelcal_" + ref)
    _text(quantity, "name", f"{name} in {unit}")
    _real(quantity, value * factor, dsi, None if expanded is None else expanded * factor,
          k=k, probability=probability, label=label)


def _response(results, curve: dict, probability: float) -> None:
    """A frequency response as one ``dcc:result``: a ``dcc:list`` of quantities per frequency.

    Each frequency's list holds the frequency (Hz), the magnitude (per
    m/s², D-SI; the certificate's output unit per g in its name) with U,
    the deviation from the reference frequency (%) with U and the phase
    (degrees) with U. A magnitude in another unit is written as text.
    """
    result = _el(results, "result")
    _text(result, "name", f"Frequency response, {curve['route']} ({curve['method']}); "
                          f"reference frequency {curve['reference_frequency_hz']:g} Hz")
    data = _el(result, "data")
    outer = _el(data, "list", refType="accelcal_frequency_response")
    for p in curve["points"]:
        point = _el(outer, "list", refType="accelcal_response_point")
        _text(point, "name", f"{p['frequency_hz']:g} Hz")
        _quantity(point, "Frequency", "frequency", p["frequency_hz"], "Hz")
        if p["unit"] in RESPONSE_UNITS:
            _quantity(point, "Sensitivity magnitude", "magnitude", p["magnitude"], p["unit"],
                      expanded=p["magnitude_U"], k=p["magnitude_k"], probability=probability,
                      label=p["coefficient"])
        else:
            _text(point, "text", f"{p['magnitude']!r} {p['unit']}, U = {p['magnitude_U']!r} "
                                 f"{p['unit']} (k = {p['magnitude_k']:.4f})")
        if p["deviation_U"] is not None:
            _quantity(point, "Deviation from the reference frequency", "deviation",
                      p["deviation_pct"], "%", expanded=p["deviation_U"], k=p["deviation_k"],
                      probability=probability)
        _quantity(point, "Phase", "phase", p["phase_deg"], "deg", expanded=p["phase_U"],
                  k=p["phase_k"], probability=probability)


def _response_model(results, m: dict, probability: float) -> None:
    """A fitted model's phase and group delay at stated frequencies, one list per frequency."""
    result = _el(results, "result")
    _text(result, "name", f"Fitted transfer function {m['model']} ({m['method']}): phase and "
                          "group delay")
    outer = _el(_el(result, "data"), "list", refType="accelcal_response_model")
    for a in m["at"]:
        point = _el(outer, "list", refType="accelcal_response_point")
        _text(point, "name", f"{a['frequency_hz']:g} Hz")
        _quantity(point, "Frequency", "frequency", a["frequency_hz"], "Hz")
        _quantity(point, "Phase", "phase", a["phase_deg"], "deg", expanded=a["phase_U"],
                  k=a["phase_k"], probability=probability)
        _quantity(point, "Group delay", "group_delay", a["group_delay_s"], "s",
                  expanded=a["group_delay_U"], k=a["group_delay_k"], probability=probability)


def to_dcc(c: dict) -> str:
    """The certificate document as DCC XML text (UTF-8, with its declaration)."""
    ET.register_namespace("dcc", DCC_NS)
    ET.register_namespace("si", SI_NS)
    root = ET.Element(_q(DCC_NS, "digitalCalibrationCertificate"),
                      {"schemaVersion": SCHEMA_VERSION})
    admin = _el(root, "administrativeData")
    software = _el(_el(admin, "dccSoftware"), "software")
    name, _, release = (c["software"] or "accelcal").partition(" ")
    _text(software, "name", name)
    _el(software, "release", release or "unknown")
    core = _el(admin, "coreData")
    _el(core, "countryCodeISO3166_1", c["laboratory"]["country"] or "ZZ")
    _el(core, "usedLangCodeISO639_1", "en")
    _el(core, "mandatoryLangCodeISO639_1", "en")
    _el(core, "uniqueIdentifier", c["number"])
    dates = sorted(d for item in c["items"] for d in item["calibrated"])
    received = sorted(i["received"] for i in c["items"] if i["received"])
    if received:
        _el(core, "receiptDate", received[0])
    _el(core, "beginPerformanceDate", dates[0])
    _el(core, "endPerformanceDate", dates[-1])
    _el(core, "performanceLocation", "laboratory")
    items = _el(admin, "items")
    for i in c["items"]:
        item = _el(items, "item")
        _text(item, "name", "Accelerometer")
        manufacturer = _el(item, "manufacturer")
        _text(manufacturer, "name", i["make"] or "not stated")
        if i["model"]:
            _el(item, "model", i["model"])
        ident = _el(_el(item, "identifications"), "identification")
        _el(ident, "issuer", "manufacturer")
        _el(ident, "value", i["serial"])
        _text(ident, "name", "Serial number")
    lab = _el(admin, "calibrationLaboratory")
    if c["laboratory"]["accreditation"]:
        _el(lab, "calibrationLaboratoryCode", c["laboratory"]["accreditation"])
    _contact(lab, "contact", c["laboratory"]["name"], c["laboratory"]["address"])
    persons = _el(admin, "respPersons")
    if c["signatory"] is not None:
        person = _el(persons, "respPerson")
        _text(_el(person, "person"), "name", c["signatory"]["name"])
        if c["signatory"]["role"]:
            _el(person, "role", c["signatory"]["role"])
        _el(person, "mainSigner", "true")
    _contact(admin, "customer", c["customer"].get("name", ""), c["customer"].get("address", ""))
    statements = [(i["serial"], r) for i in c["items"] for r in i["results"]
                  if r["conformity"] is not None]
    statements += [(i["serial"], p) for i in c["items"] for curve in i.get("response", ())
                   for p in curve["points"] if p["conformity"] is not None]
    if statements or c["expired_standards"]:
        block = _el(admin, "statements")
        for serial, r in statements:
            s = r["conformity"]
            statement = _el(block, "statement")
            _text(statement, "declaration",
                  f"{serial} {s['quantity']}: {s['statement']} by {s['rule']} acceptance "
                  f"(guard band {s['guard']!r} {s['unit']}, specific risk of a false accept "
                  f"{s['false_accept_risk']:.3g})")
            _el(statement, "conformity", {"accept": "pass", "reject": "fail"}.get(
                s["outcome"], "conditionalPass"))
        if c["expired_standards"]:
            _text(_el(block, "statement"), "declaration",
                  "Issued with standard(s) past their due date: "
                  + ", ".join(c["expired_standards"]))
    results_root = _el(root, "measurementResults")
    probability = c["coverage_probability"]
    for i in c["items"]:
        mr = _el(results_root, "measurementResult")
        _text(mr, "name", f"Calibration of accelerometer {i['serial']}")
        methods = _el(mr, "usedMethods")
        for m in i["methods"]:
            used = _el(methods, "usedMethod")
            _text(used, "name", f"{m['title']} ({m['id']})")
            if m["standard"]:
                _el(used, "norm", m["standard"])
        if c["standards"]:
            equipment = _el(mr, "measuringEquipments")
            for s in c["standards"]:
                e = _el(equipment, "measuringEquipment")
                _text(e, "name", s["description"] or s["quantity"])
                ident = _el(_el(e, "identifications"), "identification")
                _el(ident, "issuer", "calibrationLaboratory")
                _el(ident, "value", s["certificate"] or "not stated")
                _text(ident, "name", f"certificate, due {s['due'] or 'not stated'}")
        conditions = _el(mr, "influenceConditions")
        env = c["conditions"]["environment"]
        if "temperature_degC" in env:
            cond = _el(conditions, "influenceCondition")
            _text(cond, "name", "Ambient temperature")
            q = _el(_el(cond, "data"), "quantity")
            _real(q, env["temperature_degC"], r"\degreeCelsius")
        g = c["conditions"]["local_gravity"]
        if g is not None:
            cond = _el(conditions, "influenceCondition")
            _text(cond, "name", "Local acceleration of gravity")
            q = _el(_el(cond, "data"), "quantity")
            _real(q, g["value"], r"\metre\second\tothe{-2}", 2.0 * g["u"], k=2.0,
                  probability=probability)
        results = _el(mr, "results")
        for r in i["results"]:
            _result(results, r, probability)
        for curve in i.get("response", ()):
            _response(results, curve, probability)
        for m in i.get("response_models", ()):
            _response_model(results, m, probability)
    ET.indent(root, space="  ")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            + ET.tostring(root, encoding="unicode") + "\n")
