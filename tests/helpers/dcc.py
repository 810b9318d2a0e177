"""The DCC schema's rules for the elements accelcal's export writes, and a D-SI unit parser.

They restate what PTB's DCC schema (3.3.0) and the D-SI schema (2.2.0)
prescribe, so that the tests hold every exported certificate to them
without the schema files (docs/certificate.md).
"""

import datetime as dt
import math
import re

from lxml import etree

from accelcal.certificate.dcc import DCC_NS, SI_NS
from accelcal.units import STANDARD_GRAVITY as G

NS = {"dcc": DCC_NS, "si": SI_NS}

# element -> (its children in the order the schema's sequence takes them, those required)
ORDER = {
    "coreData": (["countryCodeISO3166_1", "usedLangCodeISO639_1", "mandatoryLangCodeISO639_1",
                  "uniqueIdentifier", "receiptDate", "beginPerformanceDate",
                  "endPerformanceDate", "performanceLocation", "issueDate"],
                 {"countryCodeISO3166_1", "usedLangCodeISO639_1", "mandatoryLangCodeISO639_1",
                  "uniqueIdentifier", "beginPerformanceDate", "endPerformanceDate",
                  "performanceLocation"}),
    "software": (["name", "release"], {"name", "release"}),
    "item": (["name", "manufacturer", "model", "identifications"], {"name", "identifications"}),
    "identification": (["issuer", "value", "name"], {"issuer", "value"}),
    "calibrationLaboratory": (["calibrationLaboratoryCode", "contact"], {"contact"}),
    "contact": (["name", "location"], {"name", "location"}),
    "customer": (["name", "location"], {"name", "location"}),
    "respPerson": (["person", "role", "mainSigner"], {"person"}),
    "statement": (["declaration", "conformity"], set()),
    "measurementResult": (["name", "usedMethods", "measuringEquipments", "influenceConditions",
                           "results"], {"name", "results"}),
    "usedMethod": (["name", "norm"], {"name"}),
    "measuringEquipment": (["name", "identifications"], {"name"}),
    "influenceCondition": (["name", "data"], {"name", "data"}),
    "result": (["name", "data"], {"name", "data"}),
    "quantity": (["name", "real"], {"real"}),
    "real": (["label", "value", "unit", "measurementUncertaintyUnivariate"], {"value", "unit"}),
    "expandedMU": (["valueExpandedMU", "coverageFactor", "coverageProbability"],
                   {"valueExpandedMU", "coverageFactor", "coverageProbability"}),
}
NEVER_EMPTY = ("items", "respPersons", "usedMethods", "measuringEquipments",
               "influenceConditions", "results", "statements", "identifications", "location")
"""Lists the schema requires to hold at least one entry when written."""
NON_EMPTY_STRINGS = ("uniqueIdentifier", "release", "model", "value", "norm", "role",
                     "calibrationLaboratoryCode")
"""dcc elements of the schema's non-empty string type: no leading, trailing or double space."""
ENUMS = {"issuer": {"manufacturer", "calibrationLaboratory", "customer", "owner", "other"},
         "performanceLocation": {"laboratory", "customer", "laboratoryBranch", "customerBranch",
                                 "other"},
         "conformity": {"pass", "fail", "conditionalPass", "conditionalFail", "noPass",
                        "noFail"}}
DECIMAL = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|NaN")
NON_NEGATIVE = re.compile(r"\+?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|NaN")
COVERAGE_FACTOR = re.compile(r"\+?[1-9]\d*(\.\d*)?")  # >= 1, no exponent
PROBABILITY = re.compile(r"\+?(0(\.\d*)?|1(\.0*)?)")  # in [0, 1], no exponent


def local(e) -> str:
    return etree.QName(e).localname


def violations(root) -> list[str]:
    """Every departure of the document from the rules above, as readable lines."""
    bad = []
    if root.tag != f"{{{DCC_NS}}}digitalCalibrationCertificate":
        bad.append(f"root {root.tag}")
    if root.get("schemaVersion") != "3.3.0":
        bad.append(f"schemaVersion {root.get('schemaVersion')}")
    if [local(e) for e in root] != ["administrativeData", "measurementResults"]:
        bad.append(f"root children {[local(e) for e in root]}")
    admin = {local(e) for e in root.find("dcc:administrativeData", NS)}
    missing = {"dccSoftware", "coreData", "items", "calibrationLaboratory", "respPersons",
               "customer"} - admin
    if missing:
        bad.append(f"administrativeData lacks {sorted(missing)}")
    for e in root.iter(f"{{{DCC_NS}}}*", f"{{{SI_NS}}}*"):
        name = local(e)
        children = [local(k) for k in e]
        if name in ORDER and not (name == "quantity" and e.find("si:real", NS) is None):
            order, required = ORDER[name]
            unknown = [k for k in children if k not in order]
            ranks = [order.index(k) for k in children if k in order]
            if unknown or ranks != sorted(ranks):
                bad.append(f"{name}: children {children}")
            if required - set(children):
                bad.append(f"{name}: lacks {sorted(required - set(children))}")
        if name in NEVER_EMPTY and not children:
            bad.append(f"{name} is empty")
        if e.tag.startswith(f"{{{DCC_NS}}}") and name in NON_EMPTY_STRINGS and not children:
            text = e.text or ""
            if not text or text != " ".join(text.split()):
                bad.append(f"{name}: {text!r}")
        if name in ENUMS and e.text not in ENUMS[name]:
            bad.append(f"{name}: {e.text!r}")
        for tag, pattern in (("value", DECIMAL), ("valueExpandedMU", NON_NEGATIVE),
                             ("coverageFactor", COVERAGE_FACTOR),
                             ("coverageProbability", PROBABILITY)):
            if e.tag == f"{{{SI_NS}}}{tag}" and not pattern.fullmatch(e.text or ""):
                bad.append(f"si:{tag}: {e.text!r}")
        if name in ("countryCodeISO3166_1", "countryCode") and not re.fullmatch("[A-Z]{2}",
                                                                                e.text or ""):
            bad.append(f"{name}: {e.text!r}")
        if name.endswith("Date") and e.tag.startswith(f"{{{DCC_NS}}}"):
            try:
                dt.date.fromisoformat(e.text)
            except (TypeError, ValueError):
                bad.append(f"{name}: {e.text!r}")
        if name == "content" and e.get("lang") != "en":
            bad.append(f"content lang {e.get('lang')!r}")
    return bad


# D-SI unit strings, parsed into a scale and a dimension (exponents of m, kg, s, A, K, rad)
_PREFIX = {"yocto": -24, "zepto": -21, "atto": -18, "femto": -15, "pico": -12, "nano": -9,
           "micro": -6, "milli": -3, "centi": -2, "deci": -1, "deca": 1, "hecto": 2, "kilo": 3,
           "mega": 6, "giga": 9, "tera": 12, "peta": 15, "exa": 18}
_UNIT = {"metre": (1.0, {"m": 1}), "second": (1.0, {"s": 1}), "kilogram": (1.0, {"kg": 1}),
         "ampere": (1.0, {"A": 1}), "kelvin": (1.0, {"K": 1}),
         "degreeCelsius": (1.0, {"K": 1}), "radian": (1.0, {"rad": 1}),
         "degree": (math.pi / 180, {"rad": 1}), "hertz": (1.0, {"s": -1}),
         "volt": (1.0, {"kg": 1, "m": 2, "s": -3, "A": -1}), "one": (1.0, {}),
         "percent": (1e-2, {}), "ppm": (1e-6, {})}
_TOKEN = re.compile(r"\\([a-zA-Z]+)(?:\\tothe\{(-?\d+)\})?")


def dims(*terms) -> dict:
    out = {}
    for d, n in terms:
        for k, v in d.items():
            out[k] = out.get(k, 0) + v * n
    return {k: v for k, v in out.items() if v}


def dsi_unit(unit: str) -> tuple[float, dict]:
    """The scale (to coherent SI) and the dimension of a D-SI unit string; ValueError if none."""
    scale, terms, prefix, pos = 1.0, [], 0, 0
    for m in _TOKEN.finditer(unit):
        if m.start() != pos:
            raise ValueError(f"{unit!r}: stray text at {pos}")
        pos = m.end()
        word, power = m.group(1), int(m.group(2) or 1)
        if word in _PREFIX and m.group(2) is None:
            if prefix:
                raise ValueError(f"{unit!r}: two prefixes")
            prefix = _PREFIX[word]
            continue
        if word not in _UNIT:
            raise ValueError(f"{unit!r}: unknown unit \\{word}")
        s, d = _UNIT[word]
        scale *= (10.0**prefix * s) ** power
        terms.append((d, power))
        prefix = 0
    if pos != len(unit) or prefix or not terms:
        raise ValueError(f"{unit!r}: not a D-SI unit")
    return scale, dims(*terms)


_ACC = {"m": 1, "s": -2}
_V_PER_ACC = dims(({"kg": 1, "m": 2, "s": -3, "A": -1}, 1), (_ACC, -1))
CERT_UNITS = {
    "ug": (1e-6 * G, _ACC), "mg": (1e-3 * G, _ACC), "g": (G, _ACC), "m/s^2": (1.0, _ACC),
    "ppm": (1e-6, {}), "urad": (1e-6, {"rad": 1}), "arcsec": (math.pi / 648000, {"rad": 1}),
    "mg/g": (1e-3, {}), "1": (1.0, {}), "g/g": (1.0, {}),
    "ug/g^2": (1e-6 / G, dims((_ACC, -1))), "ug/g^3": (1e-6 / G**2, dims((_ACC, -2))),
    "ug/g^4": (1e-6 / G**3, dims((_ACC, -3))),
    "ug/degC": (1e-6 * G, {"m": 1, "s": -2, "K": -1}), "ppm/degC": (1e-6, {"K": -1}),
    "urad/degC": (1e-6, {"rad": 1, "K": -1}),
    "V/g": (1.0 / G, _V_PER_ACC), "mV/g": (1e-3 / G, _V_PER_ACC),
    "mA/g": (1e-3 / G, dims(({"A": 1}, 1), (_ACC, -1))), "Hz": (1.0, {"s": -1}),
    "%": (1e-2, {}), "deg": (math.pi / 180, {"rad": 1}), "s": (1.0, {"s": 1}),
}
"""The certificate's units as (scale to coherent SI, dimension), written out independently."""
