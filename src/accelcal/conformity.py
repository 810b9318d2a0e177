"""Conformity with a specification: tolerance limits, decision rules, specific risk.

A specification file (TOML) lists tolerance limits per quantity; the same
file serves the certificate's statement of conformity and the acceptance
tests' pass/fail:

.. code-block:: toml

    title = "Acceptance specification, model QA-3000"
    document = "SPEC-0042 rev B"
    decision_rule = "guarded"          # optional: simple (default) or guarded

    [[limit]]
    quantity = "K0"                    # a coefficient or an acceptance quantity
    lower = -5000                      # one of lower/upper may be left out
    upper = 5000
    unit = "ug"                        # must fit the quantity (accelcal.units)
    serial = "SN-0042"                 # optional: only this serial
    method = "tumble"                  # optional: only records of this method
    guard = 100                        # optional guard band w, in unit (default U)

    [[limit]]                          # a frequency response's magnitude band
    quantity = "magnitude deviation"   # from the magnitude at the reference frequency
    lower = -5.0
    upper = 5.0
    unit = "%"                         # % or ppm
    band_hz = [10, 500]                # optional: the frequencies it holds over (Hz)

:func:`load_spec` reads and checks it (one-line errors); :func:`decide`
makes the decision for one estimate; :func:`evaluate` for rows
``quantity, estimate, std, unit``.

The decision (JCGM 106 section 8, ILAC-G8:2019): with tolerance limits
``T_L .. T_U`` and the measurement's PDF (a Student t with ``dof`` degrees
of freedom scaled by the standard uncertainty ``u``, normal when ``dof`` is
infinite), the *simple* rule accepts an estimate inside the tolerance
interval and rejects one outside it. The *guarded* rule shrinks the
acceptance zone to ``T_L + w .. T_U - w`` by a guard band ``w`` (by
default ``w = U = k u``, k the t-quantile at 95.45 %): an estimate in the
acceptance zone is accepted, one outside the tolerance interval rejected,
and one inside the tolerance interval but in the guard band is
*inconclusive* (ILAC-G8's conditional pass, which a binary rule counts as a
reject). The specific risk of a false accept is the PDF's mass outside the
tolerance interval, ``P(Y < T_L) + P(Y > T_U)`` (JCGM 106 section 9.3);
for a rejected estimate the specific risk of a false reject is the mass
inside.

References
----------
.. [JCGM106] JCGM 106:2012, Evaluation of measurement data - The role of
   measurement uncertainty in conformity assessment, sections 7-9.
.. [ILACG8] ILAC-G8:09/2019, Guidelines on Decision Rules and Statements of
   Conformity, section 4.
.. [GUM] JCGM 100:2008, G.3 (coverage factor from the t-distribution).
.. [DOMAIN] accelcal domain notes, section 11 (conformity).
"""

import math
from dataclasses import dataclass
from pathlib import Path

from accelcal.engineering import QUANTITIES
from accelcal.errors import AccelcalError
from accelcal.terms import TEMPERATURE_TERMS, TERMS
from accelcal.units import UNIT_SIZES, convert, unit_dimension
from accelcal.validation import shown, shown_name

RULES = ("simple", "guarded")
"""Decision rules: simple acceptance, guarded acceptance (guard band w)."""

COVERAGE_PROBABILITY = 0.9544997361036416
"""Coverage probability of U = k u: that of k = 2 for a normal PDF (GUM 6.3.3)."""

_BY_KIND = {"bias": ("acceleration",), "scale": ("voltage/g", "current/g", "ratio"),
            "ratio": ("ratio",), "misalignment": ("ratio",), "transverse": ("ratio",),
            "second": ("second-order",), "third": ("third-order",),
            "fourth": ("fourth-order",)}



def _dimensions(kind: str) -> tuple[str, ...]:
    """Dimensions of an :data:`accelcal.engineering.QUANTITIES` kind (``bias/T2``: per degC^2)."""
    base, _, power = kind.partition("/T")
    per = "" if not power else ("/degC" if power == "1" else f"/degC^{power}")
    return tuple(d + per for d in _BY_KIND[base])


QUANTITY_DIMENSIONS: dict[str, tuple[str, ...]] = {
    **{name: _dimensions(kind) for name, kind in QUANTITIES.items()},
    "sigma": ("acceleration",),
    "threshold": ("acceleration",), "resolution": ("acceleration",),
    "resolution / input": ("ratio",), "hysteresis": ("acceleration",),
    "input range": ("acceleration",), "clipped samples": ("ratio",),
    "overload bias shift": ("acceleration",),
    "bias repeatability": ("acceleration",), "scale-factor repeatability": ("ratio",),
    "bias drift": ("acceleration/time",),
    "magnetic sensitivity": ("acceleration/field",),
    "magnitude deviation": ("ratio",),
}
"""Dimensions (keys of :data:`accelcal.units.UNIT_SIZES`, with ``/degC^k``) a
limit's unit may have, per quantity: the model's coefficients (a scale
factor in an output unit per g, or in ppm of a relative deviation or
shift) and the acceptance tests' quantities. A limit on ``Q`` also applies
to the rows ``Q at ...`` and ``Q (...)`` (``hysteresis at +0.5 g``, ``input range
(+)``, ``bias repeatability (K_F)``)."""

_LIMIT_KEYS = ("quantity", "lower", "upper", "unit", "serial", "method", "guard", "band_hz")

BAND_QUANTITY = "magnitude deviation"
"""The quantity a limit may hold over a frequency band (``band_hz``): a frequency
response's deviation from its magnitude at the reference frequency."""

_BAND_UNITS = ("%", "ppm")
_SPEC_KEYS = ("title", "document", "decision_rule", "limit")


@dataclass(frozen=True)
class Limit:
    """Tolerance limits of one quantity, in ``unit`` (``None``: that side is open)."""

    quantity: str
    lower: float | None
    upper: float | None
    unit: str
    serial: str | None = None
    method: str | None = None
    guard: float | None = None
    """Guard band w in ``unit`` for the guarded rule (None: w = U)."""
    band_hz: tuple[float, float] | None = None
    """The frequencies (Hz, both included) a frequency response's limit holds over (None:
    every frequency)."""

    def covers(self, frequency_hz: float) -> bool:
        """True when the limit holds at ``frequency_hz`` (always, without a band)."""
        if self.band_hz is None:
            return True
        return self.band_hz[0] <= frequency_hz <= self.band_hz[1]

    def matches(self, quantity: str) -> bool:
        """True for the quantity itself and its rows ``<quantity> at ...``, ``<quantity> (...)``."""
        return quantity == self.quantity or quantity.startswith(
            (self.quantity + " at ", self.quantity + " ("))

    def applies(self, serial: str | None = None, method: str | None = None) -> bool:
        """True unless the limit names another serial or method (``family/x`` matches ``x``)."""
        if self.serial is not None and serial is not None and serial != self.serial:
            return False
        if self.method is not None and method is not None:
            return self.method in (method, method.rpartition("/")[2], method.partition("/")[0])
        return True


@dataclass(frozen=True)
class Spec:
    """A specification: a title, a document reference, the limits, the default rule."""

    title: str
    document: str
    limits: tuple[Limit, ...]
    decision_rule: str = "simple"

    def limits_for(self, quantity: str, *, serial=None, method=None) -> tuple[Limit, ...]:
        """The limits that apply to a row ``quantity`` of ``serial``'s ``method`` record."""
        return tuple(lim for lim in self.limits
                     if lim.matches(quantity) and lim.applies(serial, method))


@dataclass(frozen=True)
class Decision:
    """The decision on one estimate (JCGM 106, ILAC-G8; module docs).

    ``outcome`` is ``"accept"``, ``"reject"`` or (guarded rule, estimate in
    the guard band) ``"inconclusive"``. ``acceptance`` is the acceptance
    zone (``None`` for an open side; empty when ``acceptance[0] >
    acceptance[1]``). ``conforming`` is the PDF's mass inside the tolerance
    interval; ``risk`` the specific risk of the decision: a false accept
    (``1 - conforming``) for an accepted or inconclusive estimate, a false
    reject (``conforming``) for a rejected one.
    """

    outcome: str
    rule: str
    estimate: float
    u: float
    dof: float
    k: float
    lower: float | None
    upper: float | None
    guard: float
    acceptance: tuple[float | None, float | None]
    conforming: float
    risk: float

    @property
    def accepted(self) -> bool:
        """True when the outcome is an accept."""
        return self.outcome == "accept"

    @property
    def false_accept_risk(self) -> float:
        """The PDF's mass outside the tolerance interval."""
        return 1.0 - self.conforming


def coverage_factor(dof) -> float:
    """The coverage factor k for 95.45 %: 2 for infinite ``dof``, else the t-quantile."""
    from scipy.special import stdtrit

    dof = math.inf if dof is None else float(dof)
    if math.isinf(dof):
        return 2.0
    return float(stdtrit(dof, 0.5 + COVERAGE_PROBABILITY / 2.0))


def _cdf(x: float, dof: float) -> float:
    from scipy.special import ndtr, stdtr

    return float(ndtr(x) if math.isinf(dof) else stdtr(dof, x))


def decide(estimate, u, dof=None, lower=None, upper=None, *, rule: str = "simple",
           guard=None) -> Decision:
    """The conformity decision for one estimate.

    Parameters
    ----------
    estimate, u : float
        The measured value and its standard uncertainty (same unit as the limits).
    dof : float or None
        Degrees of freedom of ``u``; None or infinity: a normal PDF.
    lower, upper : float or None
        Tolerance limits T_L, T_U; None for an open side (at least one given).
    rule : {"simple", "guarded"}
        Decision rule.
    guard : float, optional
        Guard band w (guarded rule); default ``U = k u``.

    Returns
    -------
    Decision

    Raises
    ------
    AccelcalError
        For an unknown rule, no limit, ``lower > upper``, a negative or
        non-finite ``u`` or guard, non-positive ``dof``.
    """
    if rule not in RULES:
        raise AccelcalError(f"decision rule {shown(rule)} is not one of {', '.join(RULES)}",
                            parameter="decision_rule")
    if lower is None and upper is None:
        raise AccelcalError("a tolerance interval needs a lower or an upper limit")
    if lower is not None and upper is not None and lower > upper:
        raise AccelcalError(f"lower limit {lower:g} is above the upper limit {upper:g}")
    estimate, u = float(estimate), float(u)
    dof = math.inf if dof is None else float(dof)
    if not (math.isfinite(estimate) and math.isfinite(u) and u >= 0 and dof > 0):
        raise AccelcalError(f"cannot decide on estimate {estimate:g} with u {u:g} and "
                            f"{dof:g} dof: the uncertainty must be finite and >= 0, dof > 0")
    k = coverage_factor(dof)
    w = 0.0
    if rule == "guarded":
        w = k * u if guard is None else float(guard)
        if not (math.isfinite(w) and w >= 0):
            raise AccelcalError(f"the guard band must be finite and >= 0, not {w:g}")
    zone = (None if lower is None else lower + w, None if upper is None else upper - w)
    inside = ((lower is None or estimate >= lower) and (upper is None or estimate <= upper))
    in_zone = ((zone[0] is None or estimate >= zone[0])
               and (zone[1] is None or estimate <= zone[1]))
    outcome = "accept" if in_zone else ("inconclusive" if inside else "reject")
    if u > 0:
        below = 0.0 if lower is None else _cdf((lower - estimate) / u, dof)
        above = 0.0 if upper is None else 1.0 - _cdf((upper - estimate) / u, dof)
        conforming = 1.0 - below - above
    else:
        conforming = 1.0 if inside else 0.0
    risk = conforming if outcome == "reject" else 1.0 - conforming
    return Decision(outcome=outcome, rule=rule, estimate=estimate, u=u, dof=dof, k=k,
                    lower=lower, upper=upper, guard=w, acceptance=zone,
                    conforming=conforming, risk=risk)


def evaluate(spec: Spec, rows, *, serial=None, method=None, rule: str | None = None,
             dof=None) -> list[dict]:
    """Pass/fail rows for the rows ``quantity, estimate, std, unit`` a spec limits.

    Each row (a dict; an optional ``dof`` key overrides ``dof``) whose
    quantity a limit of ``spec`` matches, for ``serial`` and ``method``, is
    converted to the limit's unit and decided by ``rule`` (default the
    spec's). Rows in a unit that does not fit the limit's, or without a
    finite estimate and standard uncertainty, are skipped.

    Returns
    -------
    list of dict
        ``quantity, estimate, std, unit, lower, upper, rule, guard,
        accept_lower, accept_upper, decision, conforming, risk``.
    """
    rule = rule or spec.decision_rule
    out = []
    for row in rows:
        for lim in spec.limits_for(row["quantity"], serial=serial, method=method):
            try:
                value = float(convert(row["estimate"], row["unit"], lim.unit))
                std = float(convert(row["std"], row["unit"], lim.unit))
            except (ValueError, TypeError):
                continue
            if not (math.isfinite(value) and math.isfinite(std)):
                continue
            d = decide(value, std, row.get("dof", dof), lim.lower, lim.upper, rule=rule,
                       guard=lim.guard)
            out.append({"quantity": row["quantity"], "estimate": value, "std": std,
                        "unit": lim.unit, "lower": lim.lower, "upper": lim.upper,
                        "rule": rule, "guard": d.guard, "accept_lower": d.acceptance[0],
                        "accept_upper": d.acceptance[1], "decision": d.outcome,
                        "conforming": d.conforming, "risk": d.risk})
    return out


def load_spec(path) -> Spec:
    """Read and check a specification file (TOML; module docs).

    Raises
    ------
    AccelcalError
        One line naming the file and what is wrong: not TOML, no limits, an
        unknown key or quantity, no limit value, ``lower > upper``, a unit
        that does not fit the quantity.
    """
    import tomllib

    from accelcal.io.limits import MAX_JSON_BYTES, read_bounded

    path = Path(path)
    where = f"specification {shown_name(path.name)}"
    try:
        doc = tomllib.loads(read_bounded(path, MAX_JSON_BYTES, "specification").decode())
    except UnicodeDecodeError:
        raise AccelcalError(f"{where} is not UTF-8 text", parameter="spec") from None
    except OSError as exc:
        raise AccelcalError(f"cannot read {where}: {exc.strerror or exc.__class__.__name__}",
                            parameter="spec") from None
    except tomllib.TOMLDecodeError as exc:
        raise AccelcalError(f"{where} is not TOML: {exc}", parameter="spec") from None
    return parse_spec(doc, where)


def parse_spec(doc: dict, where: str = "specification") -> Spec:
    """Check a specification document (the parsed TOML) and build the :class:`Spec`."""
    def fail(message):
        raise AccelcalError(f"{where}: {message}", parameter="spec")

    unknown = [k for k in doc if k not in _SPEC_KEYS]
    if unknown:
        fail(f"unknown key {shown(unknown[0])}; the keys are {', '.join(_SPEC_KEYS)}")
    for key in ("title", "document"):
        if not isinstance(doc.get(key, ""), str):
            fail(f"{key} must be text")
    rule = doc.get("decision_rule", "simple")
    if rule not in RULES:
        fail(f"decision_rule {shown(rule)} is not one of {', '.join(RULES)}")
    limits = doc.get("limit")
    if not isinstance(limits, list) or not limits:
        fail("no limits: add [[limit]] tables with quantity, lower and/or upper, unit")
    return Spec(title=doc.get("title", ""), document=doc.get("document", ""),
                limits=tuple(_limit(t, i + 1, fail) for i, t in enumerate(limits)),
                decision_rule=rule)


def _limit(table, number: int, fail) -> Limit:
    if not isinstance(table, dict):
        fail(f"limit {number} must be a table")
    unknown = [k for k in table if k not in _LIMIT_KEYS]
    if unknown:
        fail(f"limit {number}: unknown key {shown(unknown[0])}; the keys are "
             f"{', '.join(_LIMIT_KEYS)}")
    quantity = table.get("quantity")
    if not isinstance(quantity, str) or quantity not in QUANTITY_DIMENSIONS:
        close = [q for q in (TERMS | TEMPERATURE_TERMS) if q.lower() == str(quantity).lower()]
        fail(f"limit {number}: quantity {shown(quantity)} is not known"
             + (f" (did you mean {close[0]}?)" if close else "")
             + "; give a coefficient (K0, K1, ...) or an acceptance quantity (threshold, "
               "resolution, hysteresis, input range, bias repeatability, ...)")
    values = {}
    for key in ("lower", "upper", "guard"):
        v = table.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)
                              or not math.isfinite(v)):
            fail(f"limit {number} ({quantity}): {key} must be a finite number, got {shown(v)}")
        values[key] = None if v is None else float(v)
    if values["lower"] is None and values["upper"] is None:
        fail(f"limit {number} ({quantity}): give lower, upper or both")
    if values["lower"] is not None and values["upper"] is not None \
            and values["lower"] > values["upper"]:
        fail(f"limit {number} ({quantity}): lower {values['lower']:g} is above upper "
             f"{values['upper']:g}")
    if values["guard"] is not None and values["guard"] < 0:
        fail(f"limit {number} ({quantity}): guard must be >= 0")
    unit = table.get("unit")
    fits = QUANTITY_DIMENSIONS[quantity]
    if not isinstance(unit, str) or unit_dimension(unit) not in fits:
        units = [u for d in fits for u in UNIT_SIZES.get(d.split("/degC")[0], {})]
        fail(f"limit {number} ({quantity}): unit {shown(unit)} does not fit the quantity; "
             f"use one of {', '.join(units)}" + (" (per degC^k)" if "/degC" in fits[0] else ""))
    for key in ("serial", "method"):
        if not isinstance(table.get(key, ""), str):
            fail(f"limit {number} ({quantity}): {key} must be text")
    if quantity == BAND_QUANTITY and unit not in _BAND_UNITS:
        fail(f"limit {number} ({quantity}): unit {shown(unit)} does not fit the quantity; "
             f"use one of {', '.join(_BAND_UNITS)}")
    return Limit(quantity=quantity, unit=unit, serial=table.get("serial"),
                 method=table.get("method"), band_hz=_band(table, quantity, number, fail),
                 **values)


def _band(table, quantity: str, number: int, fail) -> tuple[float, float] | None:
    """A limit's ``band_hz = [from, to]`` (None when not given)."""
    band = table.get("band_hz")
    if band is None:
        return None
    if quantity != BAND_QUANTITY:
        fail(f"limit {number} ({quantity}): band_hz applies to {BAND_QUANTITY} only")
    if not (isinstance(band, list) and len(band) == 2 and all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            and v > 0 for v in band) and band[0] <= band[1]):
        fail(f"limit {number} ({quantity}): band_hz must be [from, to], two frequencies in "
             f"Hz above 0, from <= to; got {shown(band)}")
    return float(band[0]), float(band[1])
