r"""The certificate as a Digital Calibration Certificate (DCC, PTB's XML schema, version 3.3).

:func:`to_dcc` writes the certificate document (:mod:`accelcal.certificate.content`)
in the structure of PTB's DCC schema, version 3.3.0 [DCC]_, with its quantities
in D-SI 2.2 [DSI]_: ``administrativeData`` (``dccSoftware``, ``coreData`` with
the unique identifier, the dates of receipt, performance and issue,
``items``, ``calibrationLaboratory``, ``respPersons``, ``customer``,
``statements`` with the conformity statements) and ``measurementResults``
with one ``measurementResult`` per serial number: its ``name``,
``usedMethods``, ``measuringEquipments`` (the standards, with their
certificates and due dates), ``influenceConditions`` (temperature, local
gravity) and ``results``, each a ``quantity`` holding an ``si:real``
(value, unit, and ``si:measurementUncertaintyUnivariate/si:expandedMU``:
the expanded uncertainty with k and the coverage probability) in D-SI
notation. A frequency response is one ``result`` whose data are a
``dcc:list`` holding one ``dcc:list`` of quantities per frequency: the
frequency, the magnitude with U (per m/s² in D-SI, its output unit per g in
the name), the deviation from the reference frequency (%) and the phase
(degrees) with U; a fitted model's phase and group delay at stated
frequencies likewise (:data:`RESPONSE_UNITS`).

What the schema requires is always written, so that a sparse lab file still
gives a valid document: a contact without an address gets the location
"not stated", a lab file without a signatory a responsible person saying so;
lists the schema forbids empty (influence conditions, methods, standards)
are left out when there is nothing to list; texts of the schema's
non-empty string type are written with their white space collapsed; a
number that is not finite is written as D-SI's ``NaN``.

The country code is the laboratory's (``--country``), ``ZZ`` (ISO 3166's
code for an unknown country) when it is not stated.

D-SI has SI units only: a result in µg is written in ``\\micro\\metre
\\second\\tothe{-2}`` (times g_n = 9.806 65 m/s²), in ppm as ``\\ppm``, in
µrad as ``\\micro\\radian``, in µg/g² as ``\\second\\tothe{2}\\metre\\tothe{-1}``
(times 1e-6 / g_n: a D-SI prefix is raised with its unit), and so on (:data:`DSI_UNITS`); the
certificate's own unit is kept as the quantity's name. A result whose unit
has no D-SI form here (an output unit, V/g) is written in its record's unit
as ``dcc:text``.

The export was validated by hand against ``dcc.xsd`` 3.3.0 and the D-SI
2.2.0 schema it imports (docs/certificate.md); the schemas are not
distributed with this package or its tests. The tests check the structure
the schema prescribes (element order, required elements, number and unit
formats) without it.

References
----------
.. [DCC] Physikalisch-Technische Bundesanstalt, Digital Calibration Certificate
   (DCC), XML schema ``dcc.xsd`` version 3.3.0, https://ptb.de/dcc/.
.. [DSI] Hutzschenreuter D. et al., SmartCom Digital System of Units (D-SI),
   XML schema version 2.2.0, PTB, 2023, doi:10.5281/zenodo.3366901.
"""

import math
import xml.etree.ElementTree as ET

from accelcal.units import STANDARD_GRAVITY

DCC_NS = "https://ptb.de/dcc"
SI_NS = "https://ptb.de/si"
SCHEMA_VERSION = "3.3.0"
NOT_STATED = "not stated"

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
    "ug/g^2": (r"\second\tothe{2}\metre\tothe{-1}", 1e-6 / _G),
    "ug/g^3": (r"\second\tothe{4}\metre\tothe{-2}", 1e-6 / _G**2),
    "ug/g^4": (r"\second\tothe{6}\metre\tothe{-3}", 1e-6 / _G**3),
    "ug/degC": (r"\micro\metre\second\tothe{-2}\kelvin\tothe{-1}", _G),
    "ppm/degC": (r"\ppm\kelvin\tothe{-1}", 1.0),
    "urad/degC": (r"\micro\radian\kelvin\tothe{-1}", 1.0),
    "1": (r"\one", 1.0),
    "g/g": (r"\one", 1.0),
}
"""Certificate unit -> (D-SI unit, factor from the certificate's value to the D-SI one).

A prefix in D-SI belongs to its unit and is raised with it (``\\micro\\second\\tothe{2}``
is (µs)² = 1e-12 s²), so the nonlinearity coefficients, µg/g^n, are written in coherent
units, s^(2n-2)/m^(n-1), times 1e-6 / g_n^(n-1).
"""

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


def _word(text) -> str:
    """A text of the schema's non-empty string type: white space collapsed, never empty."""
    return " ".join(str(text or "").split()) or NOT_STATED


def _num(x: float) -> str:
    """A D-SI number: the shortest round-trip decimal, ``NaN`` when not finite."""
    x = float(x)
    return repr(x) if math.isfinite(x) else "NaN"


def _text(parent, tag: str, text: str):
    """A ``dcc:textBlock``: ``<tag><dcc:content lang="en">text</dcc:content></tag>``."""
    block = _el(parent, tag)
    _el(block, "content", text, lang="en")
    return block


def _real(parent, value: float, unit: str, expanded: float | None = None, *, k: float = 2.0,
          probability: float = 0.9545, label: str | None = None):
    """An ``si:real``: value and D-SI unit, with its expanded uncertainty when given.

    The uncertainty is D-SI 2.2's ``measurementUncertaintyUnivariate``
    holding an ``expandedMU`` (U, k and the coverage probability; D-SI
    writes k >= 1 and the probability without an exponent).
    """
    real = _el(parent, "real", ns=SI_NS)
    if label:
        _el(real, "label", label, ns=SI_NS)
    _el(real, "value", _num(value), ns=SI_NS)
    _el(real, "unit", unit, ns=SI_NS)
    if expanded is not None:
        mu = _el(_el(real, "measurementUncertaintyUnivariate", ns=SI_NS), "expandedMU",
                 ns=SI_NS)
        _el(mu, "valueExpandedMU", _num(expanded), ns=SI_NS)
        _el(mu, "coverageFactor", f"{float(k):.4f}", ns=SI_NS)
        _el(mu, "coverageProbability", f"{float(probability):.6f}".rstrip("0").rstrip("."),
            ns=SI_NS)
    return real


def _contact(parent, tag: str, name: str, address: str = "", country: str = ""):
    """A ``dcc:contactType``: the name and a location (required; "not stated" without one)."""
    contact = _el(parent, tag)
    _text(contact, "name", name or NOT_STATED)
    location = _el(contact, "location")
    if country:
        _el(location, "countryCode", country)
    if address or not country:
        _text(location, "further", address or NOT_STATED)
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


def _core(admin, c: dict) -> None:
    """``coreData``: country, languages, identifier, the dates and the place."""
    core = _el(admin, "coreData")
    _el(core, "countryCodeISO3166_1", c["laboratory"]["country"] or "ZZ")
    _el(core, "usedLangCodeISO639_1", "en")
    _el(core, "mandatoryLangCodeISO639_1", "en")
    _el(core, "uniqueIdentifier", _word(c["number"]))
    dates = sorted(d for item in c["items"] for d in item["calibrated"])
    received = sorted(i["received"] for i in c["items"] if i["received"])
    if received:
        _el(core, "receiptDate", received[0])
    _el(core, "beginPerformanceDate", dates[0])
    _el(core, "endPerformanceDate", dates[-1])
    _el(core, "performanceLocation", "laboratory")
    _el(core, "issueDate", c["issued"])


def _items(admin, c: dict) -> None:
    """``items``: one ``item`` per serial number, identified by the manufacturer's serial."""
    items = _el(admin, "items")
    for i in c["items"]:
        item = _el(items, "item")
        _text(item, "name", "Accelerometer")
        _text(_el(item, "manufacturer"), "name", i["make"] or NOT_STATED)
        if (i["model"] or "").strip():
            _el(item, "model", _word(i["model"]))
        ident = _el(_el(item, "identifications"), "identification")
        _el(ident, "issuer", "manufacturer")
        _el(ident, "value", _word(i["serial"]))
        _text(ident, "name", "Serial number")


def _people(admin, c: dict) -> None:
    """``calibrationLaboratory``, ``respPersons`` (never empty) and ``customer``."""
    lab = _el(admin, "calibrationLaboratory")
    if (c["laboratory"]["accreditation"] or "").strip():
        _el(lab, "calibrationLaboratoryCode", _word(c["laboratory"]["accreditation"]))
    _contact(lab, "contact", c["laboratory"]["name"], c["laboratory"]["address"],
             c["laboratory"]["country"])
    person = _el(_el(admin, "respPersons"), "respPerson")
    if c["signatory"] is None:
        _text(_el(person, "person"), "name", "No authorised signatory is named in the lab file")
    else:
        _text(_el(person, "person"), "name", c["signatory"]["name"])
        if (c["signatory"]["role"] or "").strip():
            _el(person, "role", _word(c["signatory"]["role"]))
        _el(person, "mainSigner", "true")
    _contact(admin, "customer", c["customer"].get("name", ""), c["customer"].get("address", ""))


def _statements(admin, c: dict) -> None:
    """``statements``: the conformity statements and the expired standards, if any."""
    statements = [(i["serial"], r) for i in c["items"] for r in i["results"]
                  if r["conformity"] is not None]
    statements += [(i["serial"], p) for i in c["items"] for curve in i.get("response", ())
                   for p in curve["points"] if p["conformity"] is not None]
    if not statements and not c["expired_standards"]:
        return
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
              "Issued with standard(s) past their due date: " + ", ".join(c["expired_standards"]))


def _circumstances(mr, i: dict, c: dict, probability: float) -> None:
    """A serial's ``usedMethods``, ``measuringEquipments`` and ``influenceConditions``.

    Each is written only when it has an entry: the schema forbids them empty.
    """
    if i["methods"]:
        methods = _el(mr, "usedMethods")
        for m in i["methods"]:
            used = _el(methods, "usedMethod")
            _text(used, "name", f"{m['title']} ({m['id']})")
            if (m["standard"] or "").strip():
                _el(used, "norm", _word(m["standard"]))
    if c["standards"]:
        equipment = _el(mr, "measuringEquipments")
        for s in c["standards"]:
            e = _el(equipment, "measuringEquipment")
            _text(e, "name", s["description"] or s["quantity"])
            ident = _el(_el(e, "identifications"), "identification")
            _el(ident, "issuer", "calibrationLaboratory")
            _el(ident, "value", _word(s["certificate"]))
            _text(ident, "name", f"certificate, due {s['due'] or NOT_STATED}")
    env = c["conditions"]["environment"]
    g = c["conditions"]["local_gravity"]
    if "temperature_degC" not in env and g is None:
        return
    conditions = _el(mr, "influenceConditions")
    if "temperature_degC" in env:
        cond = _el(conditions, "influenceCondition")
        _text(cond, "name", "Ambient temperature")
        _real(_el(_el(cond, "data"), "quantity"), env["temperature_degC"], r"\degreeCelsius")
    if g is not None:
        cond = _el(conditions, "influenceCondition")
        _text(cond, "name", "Local acceleration of gravity")
        _real(_el(_el(cond, "data"), "quantity"), g["value"], r"\metre\second\tothe{-2}",
              2.0 * g["u"], k=2.0, probability=probability)


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
    _el(software, "release", _word(release or "unknown"))
    _core(admin, c)
    _items(admin, c)
    _people(admin, c)
    _statements(admin, c)
    results_root = _el(root, "measurementResults")
    probability = c["coverage_probability"]
    for i in c["items"]:
        mr = _el(results_root, "measurementResult")
        _text(mr, "name", f"Calibration of accelerometer {i['serial']}")
        _circumstances(mr, i, c, probability)
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
