"""The certificate's content: one JSON-ready document from the records and the lab file.

:func:`build` gathers what ISO/IEC 17025 7.8 asks of a calibration
certificate [ISO17025]_ (DOMAIN.md section 11) into one dict, the
machine-readable certificate (``schema/certificate.schema.json``), which
the HTML, PDF and DCC renderings only lay out. Nothing in it depends on
the clock or the machine: the same records, lab file, options and issue
date give the same document, byte for byte once written, so a certificate
is reissued identically. Its number, unless given, is derived from the
records' content (their budget blocks left out) and the lab file's SHA-256.

The expanded uncertainty of each result is that of its budget: ``U = k
u_c`` with ``k`` Student's t at 95.45 % for the Welch-Satterthwaite
degrees of freedom [GUM]_ (:mod:`accelcal.budget.gum`). A record that kept
its budgets (``budget`` block, :mod:`accelcal.io.calibration_record`) for a
lab file of the same SHA-256 is certified from them, so a later accelcal
reissues the same numbers; otherwise the budgets are made from the record
and the lab file by :func:`accelcal.budget.budgets` (:func:`engine_budgets`), or from
the record's own uncertainties for a method without a measurement model
(:func:`typea_budgets`).

References
----------
.. [ISO17025] ISO/IEC 17025:2017, General requirements for the competence of
   testing and calibration laboratories, 7.8.2 and 7.8.4.
.. [GUM] JCGM 100:2008 (GUM), 6.3 and annex G.
.. [JCGM106] JCGM 106:2012, The role of measurement uncertainty in
   conformity assessment, secs. 7-9 (:mod:`accelcal.conformity`).
"""

import datetime as _dt
import hashlib
import json
import math
import re
from dataclasses import dataclass, replace

from accelcal.errors import AccelcalError

FORMAT_VERSION = 1
KIND = "accelcal.Certificate"
TITLE = "Calibration certificate"

STANDARDS = {
    "Dong2014": "Dong C., Liu Q., Ren S., Test methods of four integrated accelerometers "
                "on an indexing head (2014), as corrected in accelcal",
    "GuanTang": "Guan W., Tang L., Shaker test method of transverse sensitivity of inertial "
                "accelerometers, after ISO 16063-31",
    "Guan2021": "Guan W., Metrology & Measurement Technology 41(3), 2021 (vibration "
                "rectification)",
    "IEEE1293": "IEEE Std 1293-2018",
    "IEEE836": "IEEE Std 836-2009 (precision centrifuge testing)",
    "IEEE952": "IEEE Std 952-1997, Annex C (Allan variance)",
    "Tedaldi2014": "Tedaldi D. et al., IEEE ICRA 2014; Ferraris F. et al., Sensors and "
                   "Materials 7(5), 1995",
    "ISO16063-21": "ISO 16063-21:2003 (comparison to a reference transducer)",
}
"""The standard or paper each method follows, by its descriptor's ``paper`` key
(docs/references.md)."""


@dataclass(frozen=True)
class Item:
    """What the certificate says of the calibrated item beyond its serial number."""

    make: str = ""
    model: str = ""
    received: str = ""
    """Date of receipt, ISO 8601 (empty: not stated)."""


def record_digest(record) -> str:
    """SHA-256 of a record's content without its budget block (what it certifies)."""
    data = record.to_dict()
    data.pop("budget", None)
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def certificate_number(records, lab) -> str:
    """``AC-`` and 12 hex digits of the SHA-256 of the records' digests and the lab file's.

    The records' order does not matter; a changed record or lab file gives
    another number.
    """
    digest = hashlib.sha256()
    for d in sorted(record_digest(r) for r in records):
        digest.update(d.encode())
    digest.update(lab.sha256.encode())
    return "AC-" + digest.hexdigest()[:12].upper()


def typea_budgets(record) -> list[dict]:
    """Budgets of a record's coefficients from its own uncertainties alone (Type A).

    What a certificate states for a record whose method has no measurement
    model in :mod:`accelcal.budget` (the record's own standard uncertainty,
    with its degrees of freedom: Student's t, normal when unknown).
    """
    from accelcal.budget.gum import Input, combine

    if record.is_complex:
        from accelcal.certificate.response import typea_budgets as response_budgets

        return response_budgets(record)
    dof = math.inf if record.dof is None else float(record.dof)
    out = []
    for name, value, std in zip(record.names, record.estimates, record.std, strict=True):
        unit = record.units.get(name, "")
        if not math.isfinite(std):
            continue
        typea = Input("Type A", float(value), float(std), unit,
                      "student-t" if math.isfinite(dof) else "normal", dof,
                      source="type A", reference=record.method)
        out.append(combine(name, float(value), unit, [(typea, 1.0)],
                           serial=record.serial).as_dict())
    return out


def engine_budgets(paths, records, lab, search=()) -> list[list[dict] | None]:
    """The budgets :func:`accelcal.budget.budgets` makes for each record (None: none).

    The records are reduced again from their input files, found by name and
    SHA-256 as ``accelcal report`` finds them (``search``: more
    directories); when the files are not found the budgets keep the
    records' own numbers and leave out the inputs that enter through the
    data (their notes say so). A record of a method without a measurement
    model gets None.
    """
    from accelcal.report.budgets import calibration_budgets

    made = calibration_budgets(paths, lab, search)
    return [made.get((rec.serial, rec.method)) for rec in records]


def kept_budgets(record, lab) -> list[dict] | None:
    """The budgets a record kept for this lab file (None: none kept, or another lab file's)."""
    block = record.budget
    if block is None or block["lab"]["sha256"] != lab.sha256:
        return None
    return block["budgets"]


def budget_block(budgets: list[dict], lab) -> dict:
    """The ``budget`` block a record keeps (:mod:`accelcal.io.calibration_record`)."""
    return {"lab": {"sha256": lab.sha256, "path": lab.path.name, "name": lab.laboratory.name},
            "standards": [{"quantity": s["quantity"], "certificate": s["certificate"],
                           "due": s["due"]} for s in standards_used(lab, budgets)],
            "budgets": budgets}


def with_budgets(record, lab, budgets: list[dict]):
    """The record keeping ``budgets`` for ``lab`` (itself when it keeps them already)."""
    if kept_budgets(record, lab) is not None:
        return record
    return replace(record, budget=budget_block(budgets, lab))


def record_budgets(records, lab, fresh=None) -> list[list[dict]]:
    """The budgets a certificate states for each record.

    Those the record kept for this lab file first (so a certificate is
    reissued from them identically), else ``fresh`` (from
    :func:`engine_budgets`), else :func:`typea_budgets`.
    """
    fresh = fresh or [None] * len(records)
    return [kept_budgets(r, lab) or f or typea_budgets(r)
            for r, f in zip(records, fresh, strict=True)]


def standards_used(lab, budgets) -> list[dict]:
    """The lab's standards that enter the budgets (every declared one when none does).

    Each as ``{quantity, description, certificate, due, value, unit, u}``, in
    the lab file's order.
    """
    named = {row["quantity"] for b in budgets for row in b["rows"] if row.get("source") == "lab"}
    chosen = [s for q, s in lab.standards.items() if q in named] or list(lab.standards.values())
    return [{"quantity": s.quantity, "description": s.description,
             "certificate": s.certificate, "due": s.due.isoformat() if s.due else None,
             "value": s.value, "unit": s.unit, "u": s.u} for s in chosen]


def _engineering(name, value, u_c, big_u, unit, *, scale_factor):
    """The result in the field's units: ``[{estimate, u, U, unit}]`` (empty: none applies)."""
    from accelcal.engineering import engineering

    ratio = big_u / u_c if u_c > 0 else 0.0
    return [{"estimate": e.estimate, "u": e.std, "U": e.std * ratio, "unit": e.unit}
            for e in engineering(name, value, u_c, unit, scale_factor=scale_factor)]


_ARCSEC_PER_URAD = 1e-6 / (math.pi / 648000.0)


def _result(rec, name: str, b: dict, scale_factor) -> dict:
    """One result: the record's value with the budget's uncertainty, in the field's units.

    A budget in the record's unit (:func:`typea_budgets`) is converted to the
    field's units as the report converts coefficients
    (:func:`accelcal.engineering.engineering`); a budget the engine made in an
    engineering unit is that unit's result, and its uncertainty is brought
    back to the record's unit by the ratio of its Type A row to the record's
    standard uncertainty. A scale factor's budget in ppm of its own value
    (no nominal) is its relative uncertainty.
    """
    from accelcal.engineering import QUANTITIES

    i = rec.names.index(name)
    value, std, unit = float(rec.estimates[i]), float(rec.std[i]), rec.units.get(name, "")
    plain = rec.plain.get(name, name)
    base = {"coefficient": name, "plain": plain, "method": rec.method,
            "nu_eff": b["nu_eff"], "k": b["k"], "relative": None}
    if b["unit"] == unit:
        return {**base, "estimate": value, "unit": unit, "u_c": b["u_c"], "U": b["U"],
                "engineering": _engineering(plain, value, b["u_c"], b["U"], unit,
                                            scale_factor=scale_factor)}
    typea = next((r["u"] for r in b["rows"] if r.get("source") == "type A"), 0.0)
    factor = typea / std if typea > 0 and std > 0 else math.nan
    relative = QUANTITIES.get(plain) == "scale" and b["unit"] == "ppm" and b["estimate"] == 0.0
    if not math.isfinite(factor):  # no way back to the record's unit: the budget's result
        return {**base, "estimate": b["estimate"], "unit": b["unit"], "u_c": b["u_c"],
                "U": b["U"], "engineering": []}
    out = {**base, "estimate": value, "unit": unit, "u_c": b["u_c"] / factor,
           "U": b["U"] / factor, "engineering": []}
    if relative:
        out["relative"] = {"u": b["u_c"], "U": b["U"], "unit": "ppm"}
        return out
    out["engineering"].append({"estimate": b["estimate"], "u": b["u_c"], "U": b["U"],
                               "unit": b["unit"]})
    if b["unit"] == "urad":
        out["engineering"].append({"estimate": b["estimate"] * _ARCSEC_PER_URAD,
                                   "u": b["u_c"] * _ARCSEC_PER_URAD,
                                   "U": b["U"] * _ARCSEC_PER_URAD, "unit": "arcsec"})
    return out


def _scale_factor(record):
    """The record's scale factor in output unit per g (K_I or K1, else its model's)."""
    for name in ("K_I", "K1"):
        if name in record.names:
            return float(record.estimates[record.names.index(name)])
    return float(record.model.K1) if record.model is not None else None


def _inputs_in(records, stated) -> set[str]:
    """The lab inputs whose due dates a certificate checks.

    Every input of each record's measurement model (its test's own, for a
    family whose tests differ: :func:`accelcal.budget.model_inputs`), and
    every lab input that enters the stated budgets.
    """
    from types import SimpleNamespace

    from accelcal.budget import model_inputs

    taken = {q for r in records for q in model_inputs(SimpleNamespace(
        family=r.method.partition("/")[0], method=r.method, provenance={}, observations={}))}
    return taken | {row["quantity"] for budgets_of in stated for b in budgets_of
                    for row in b["rows"] if row.get("source") == "lab"}


def _method(record) -> dict:
    from accelcal.catalog import METHODS
    from accelcal.certificate import response

    family = record.method.partition("/")[0]
    for m in METHODS:
        if m.family == family:
            if response.is_response(record) and record.method in response.ROUTES:
                route, paper = response.ROUTES[record.method]
                return {"id": record.method, "title": f"{m.title}, {route}",
                        "standard": {**STANDARDS, **response.STANDARDS}[paper]}
            return {"id": record.method, "title": m.title,
                    "standard": STANDARDS.get(m.paper, m.paper)}
    return {"id": record.method, "title": record.method, "standard": ""}


def _response(page, rec, budgets_of, lab, *, spec, rule, phase_at) -> list[dict]:
    """Put a frequency-response record on its page; the budgets it adds to the annex.

    A complex record's points go to ``page["response"]`` (with a statement
    of conformity per point a magnitude band limits); a model fit's
    phases and group delays to ``page["response_models"]``
    (:mod:`accelcal.certificate.response`).
    """
    from accelcal.certificate import response
    from accelcal.methods.response.stepped import REFERENCE_FREQUENCY

    if rec.is_complex:
        c = response.curve(rec, budgets_of)
        if not c["points"]:
            raise AccelcalError(f"record of {rec.serial} ({rec.method}): no budget of any "
                                "point's magnitude and phase; issue it again without its kept "
                                "budgets", parameter="records")
        for point in c["points"]:
            point["conformity"] = (None if spec is None else response.conformity(
                spec, rule, point, serial=rec.serial, method=rec.method,
                statements=STATEMENTS))
        page.setdefault("response", []).append(c)
        return []
    if rec.method != response.FIT:
        return []
    at = list(phase_at) or list(dict.fromkeys(
        c["reference_frequency_hz"] for c in page.get("response", ()))) or [REFERENCE_FREQUENCY]
    fitted, made = response.model(rec, lab, at)
    page.setdefault("response_models", []).append(fitted)
    return [{**b, "serial": rec.serial, "method": rec.method} for b in made]


def _conformity(spec, rule, result, serial, method):
    """The statement of conformity of one result (None: no limit applies)."""
    from accelcal.conformity import decide
    from accelcal.units import convert

    name = result["plain"]
    limits = spec.limits_for(name, serial=serial, method=method)
    if not limits:
        return None
    lim = limits[0]
    candidates = [(e["estimate"], e["u"], e["unit"]) for e in result["engineering"]]
    candidates.append((result["estimate"], result["u_c"], result["unit"]))
    for value, u, unit in candidates:
        try:
            value_l, u_l = float(convert(value, unit, lim.unit)), float(convert(u, unit,
                                                                                lim.unit))
        except ValueError:
            continue
        dof = None if result["nu_eff"] == "inf" else result["nu_eff"]
        big_u = result["k"] * abs(u_l)  # the certificate's U: the guard band w = U by default
        d = decide(value_l, abs(u_l), dof, lim.lower, lim.upper, rule=rule,
                   guard=big_u if lim.guard is None else lim.guard)
        return {"quantity": name, "estimate": value_l, "u": abs(u_l), "U": big_u,
                "unit": lim.unit, "lower": lim.lower, "upper": lim.upper, "rule": rule,
                "guard": d.guard, "acceptance": list(d.acceptance), "outcome": d.outcome,
                "statement": STATEMENTS[d.outcome], "conforming": d.conforming,
                "false_accept_risk": d.false_accept_risk}
    raise AccelcalError(f"specification: the limit on {name} is in {lim.unit}, which the "
                        f"result of {serial} ({result['unit']}) cannot be expressed in",
                        parameter="spec")


STATEMENTS = {"accept": "conforms", "reject": "does not conform",
              "inconclusive": "inconclusive (in the guard band)"}
"""The statement of conformity of each decision outcome."""


_NUMBER = re.compile(r"[A-Za-z0-9][A-Za-z0-9._/-]{0,63}")
"""A certificate number given by the laboratory."""


def _utc_date(text: str) -> _dt.date:
    """The UTC date of an ISO 8601 date and time (its own date when it has no offset)."""
    moment = _dt.datetime.fromisoformat(text)
    return (moment.astimezone(_dt.UTC) if moment.tzinfo is not None else moment).date()


def _date(text: str) -> str:
    return _dt.datetime.fromisoformat(text).date().isoformat()


def build(records, lab, *, issued: str, number: str | None = None, item: Item | None = None,
          spec=None, rule: str | None = None, allow_expired: bool = False,
          software: str = "", country: str = "", budgets=None, phase_at=()) -> dict:
    """The certificate document (``schema/certificate.schema.json``).

    Parameters
    ----------
    records : sequence of CalibrationRecord
        Real-coefficient records (one page of results per serial number).
    lab : accelcal.budget.lab.Lab
    issued : str
        Date of issue, ISO 8601.
    number : str, optional
        The certificate's number (default :func:`certificate_number`).
    item : Item, optional
        Make, model and date of receipt (default: not stated).
    spec : accelcal.conformity.Spec, optional
        With it, a statement of conformity per limited result by ``rule``
        (default the spec's).
    allow_expired : bool
        Issue even when a standard that enters the records' budgets (a
        row of the lab's) was past its due date on a calibration date (the
        certificate says so); otherwise refuse. The lab's other standards,
        those of other methods or of a family's other tests, do not stop a
        certificate.
    software : str
        ``"accelcal <version>"``.
    country : str
        The laboratory's country, ISO 3166-1 alpha-2 (empty: not stated).
    budgets : list, optional
        Fresh budgets of each record (:func:`engine_budgets`), used where a
        record kept none for this lab file (:func:`record_budgets`).
    phase_at : sequence of float
        Frequencies (Hz) of a fitted frequency-response model's phase and
        group delay (default: the reference frequency of the serial's
        measured response, else 80 Hz; :mod:`accelcal.certificate.response`).

    Raises
    ------
    AccelcalError
        No records, a bad date or an expired standard.
    """
    if not records:
        raise AccelcalError("a certificate needs at least one calibration record")
    if country and not (len(country) == 2 and country.isascii() and country.isupper()):
        raise AccelcalError(f"country {country!r} is not an ISO 3166-1 alpha-2 code (DE, GB, "
                            "US, ...)", parameter="country")
    if number is not None and not _NUMBER.fullmatch(number):
        raise AccelcalError(f"certificate number {number!r}: use 1 to 64 letters, digits and "
                            "the signs - _ . /", parameter="number")
    bad = [f for f in phase_at if not (isinstance(f, int | float) and 0 < f <= 1e9)]
    if bad:
        raise AccelcalError(f"--phase-at: frequencies must be above 0 and up to 1e9 Hz, got "
                            f"{bad[0]!r}", parameter="phase_at")
    try:
        issued = _dt.date.fromisoformat(issued).isoformat()
    except (TypeError, ValueError):
        raise AccelcalError(f"issue date {issued!r} is not an ISO 8601 date (2026-11-26)",
                            parameter="issued") from None
    item = item or Item()
    if item.received:
        try:
            item = replace(item, received=_dt.date.fromisoformat(item.received).isoformat())
        except ValueError:
            raise AccelcalError(f"date of receipt {item.received!r} is not an ISO 8601 date "
                                "(2026-11-20)", parameter="received") from None
    dates = sorted(_utc_date(r.date) for r in records)
    used_on = dates[-1]
    if issued < used_on.isoformat():
        raise AccelcalError(f"issue date {issued} is before the calibration of "
                            f"{used_on.isoformat()}", parameter="issued")
    if item.received and item.received > dates[0].isoformat():
        raise AccelcalError(f"date of receipt {item.received} is after the calibration of "
                            f"{dates[0].isoformat()}", parameter="received")
    rule = (rule or spec.decision_rule) if spec is not None else None
    from accelcal.certificate import response

    all_budgets, serials = [], {}
    stated = record_budgets(records, lab, budgets)
    inputs = _inputs_in(records, stated)
    expired = [s for s in lab.expired(used_on) if s.quantity in inputs]
    if expired and not allow_expired:
        names = ", ".join(f"{s.quantity} (certificate {s.certificate or '?'}, due {s.due})"
                          for s in expired)
        raise AccelcalError(f"{lab.path.name}: standard(s) past their due date on "
                            f"{used_on.isoformat()}: {names}; recalibrate them, or give "
                            "--allow-expired to issue a certificate that says so",
                            parameter="lab")
    for rec, budgets_of in sorted(zip(records, stated, strict=True),
                                  key=lambda p: (p[0].serial, p[0].method, p[0].date)):
        by_name = {b["coefficient"]: b for b in budgets_of}
        k1 = _scale_factor(rec)
        results = []
        for name in ([] if rec.is_complex else rec.names):
            if name in by_name:
                res = _result(rec, name, by_name[name], k1)
                res["conformity"] = (None if spec is None
                                     else _conformity(spec, rule, res, rec.serial, rec.method))
                results.append(res)
        all_budgets += [{**b, "serial": rec.serial, "method": rec.method} for b in budgets_of]
        page = serials.setdefault(rec.serial, {
            "serial": rec.serial, "make": item.make, "model": item.model,
            "received": item.received or None, "calibrated": [], "methods": [],
            "operators": [], "simulated": False, "results": [],
            "records": []})
        page["calibrated"].append(_date(rec.date))
        method = _method(rec)
        if method not in page["methods"]:
            page["methods"].append(method)
        if rec.operator and rec.operator not in page["operators"]:
            page["operators"].append(rec.operator)
        page["simulated"] = page["simulated"] or rec.simulated
        page["results"] += results
        if response.is_response(rec):
            all_budgets += _response(page, rec, budgets_of, lab, spec=spec, rule=rule,
                                     phase_at=phase_at)
        page["records"].append({"method": rec.method, "date": rec.date,
                                "sha256": record_digest(rec)})
    for page in serials.values():
        page["calibrated"] = sorted(set(page["calibrated"]))
    gravity = lab.standards.get("local_gravity")
    conditions = {"environment": {str(k): v if isinstance(v, int | float | str) else str(v)
                                  for k, v in lab.environment.items()},
                  "local_gravity": None if gravity is None else {
                      "value": gravity.value_in("m/s^2"), "u": gravity.u_in("m/s^2"),
                      "unit": "m/s^2", "certificate": gravity.certificate}}
    signatory = lab.signatories[0] if lab.signatories else None
    standards = standards_used(lab, all_budgets)
    for s in standards:
        s["expired"] = any(e.quantity == s["quantity"] for e in expired)
    return {
        "format_version": FORMAT_VERSION, "kind": KIND, "title": TITLE,
        "number": number or certificate_number(records, lab), "issued": issued,
        "software": software,
        "laboratory": {"name": lab.laboratory.name, "address": lab.laboratory.address,
                       "accreditation": lab.laboratory.accreditation, "country": country},
        "lab_file": {"name": lab.path.name, "sha256": lab.sha256},
        "customer": {str(k): str(v) for k, v in (lab.customer or {}).items()},
        "signatory": None if signatory is None else {"name": signatory.name,
                                                     "role": signatory.role},
        "conditions": conditions,
        "coverage_probability": 0.9545,
        "standards": standards,
        "expired_standards": [e.quantity for e in expired],
        "decision_rule": None if spec is None else {
            "rule": rule, "specification": spec.title, "document": spec.document},
        "items": list(serials.values()),
        "budgets": all_budgets,
    }
