"""Frequency responses on a certificate: the points per frequency and the fitted model's phases.

A frequency-response record holds complex coefficients ``S(f Hz)`` (the
DUT's sensitivity at each step, :mod:`accelcal.methods.response`); its
budgets (:func:`accelcal.budget.budgets`) give each step's magnitude in %
of its estimate and its phase in degrees. :func:`curve` turns them into the
certificate's points [ISO16063-21]_:

- the magnitude in the output unit per g with ``U = U_% |S| / 100`` and
  the budget's ``k``;
- the deviation from the reference frequency's magnitude,
  ``100 (|S(f)| / |S(f_ref)| - 1)`` in % and ``20 log10(|S(f)| / |S(f_ref)|)``
  in dB, with the uncertainty of the difference of the two steps' budgets
  less the inputs common to every step with the same coefficient
  (:data:`COMMON`: the reference accelerometer's sensitivity, the DAQ's
  channel gain mismatch, the DUT's temperature and its coefficient, which
  cancel in the ratio), the remaining inputs of the two steps taken as
  independent, ``k`` for its Welch-Satterthwaite degrees of freedom [GUM]_;
- the phase in degrees (negative: the output lags the input) with its
  budget's ``U`` and ``k``.

A model-fit record (``response/model-fit``: ``S0``, ``fn``, ``zeta``,
``f_3dB`` and the extra pole or delay where fitted) is certified as other
records are (its results, with the budgets of the comparison's inputs
through the points it was fitted to,
:mod:`accelcal.methods.response.budget_fit`); :func:`model` adds the fitted model's phase and
group delay ``tau_g = -d phi / d omega`` at stated frequencies, propagated
from the record's covariance by numerical gradients, the phase's budget
with the reference accelerometer's phase (a common offset of every step,
``c = 1``; it does not change the group delay).

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Vibration calibration by comparison to a
   reference transducer, secs. 6-7 (magnitude and phase of the complex
   sensitivity, the reference frequency).
.. [GUM] JCGM 100:2008, 5.1 and G.4 (propagation, Welch-Satterthwaite).
"""

import math
import re

FAMILY = "response"
FIT = "response/model-fit"
COMMON = ("reference_sensitivity", "daq_gain_mismatch", "sensor_temperature",
          "sensitivity_tc")
"""Inputs common to every step's magnitude with the same sensitivity (1 % per % of the
reference's sensitivity and of the channels' gain ratio, ``alpha`` per degC, ``dT`` per
unit of the coefficient): they cancel in the deviation from the reference frequency."""

_REFERENCE = re.compile(r"deviations from the sensitivity at (S\(.+\))$")

ROUTES = {
    "response/comparison": ("comparison with a reference accelerometer, stepped sine",
                            "ISO16063-21"),
    "response/broadband": ("comparison with a reference accelerometer, broadband excitation",
                           "ISO16063-21"),
    "response/laser": ("primary calibration by laser interferometry (sine approximation)",
                       "ISO16063-11"),
    "response/gravity": ("calibration by the Earth's gravitation on a rotating table",
                         "ISO16063-16"),
    FIT: ("transfer function fitted to the frequency response", "ISO16063-21"),
}
"""Method id -> (the route in words, the standard's key in the certificate's STANDARDS)."""

STANDARDS = {
    "ISO16063-11": "ISO 16063-11:1999 (primary vibration calibration by laser "
                   "interferometry, method 3)",
    "ISO16063-16": "ISO 16063-16:2014 (calibration by Earth's gravitation)",
}
"""The frequency response's standards beside ISO 16063-21 (docs/references.md)."""


def is_response(record) -> bool:
    """True for a record of the frequency-response family (points or a model fit)."""
    return record.method.partition("/")[0] == FAMILY


def _inf(x) -> float:
    return math.inf if x in (None, "inf") else float(x)


def _dof(x):
    return "inf" if math.isinf(x) else x


def typea_budgets(record) -> list[dict]:
    """Budgets of a complex record's steps from its own uncertainties alone (Type A).

    Each step's magnitude (in % of its estimate) and phase (deg), as
    :func:`accelcal.budget.budgets` names them, for a record whose budgets
    cannot be made from its data and the lab file.
    """
    from accelcal.budget.gum import Input, combine

    pol = record.polar()
    dof = math.inf if record.dof is None else float(record.dof)
    dist = "student-t" if math.isfinite(dof) else "normal"
    out = []
    for i, name in enumerate(record.names):
        mag, phase = float(pol.magnitude[i]), math.degrees(float(pol.phase[i]))
        u_mag, u_phase = float(pol.magnitude_std[i]), math.degrees(float(pol.phase_std[i]))
        if mag > 0 and math.isfinite(u_mag):
            typea = Input("Type A", 0.0, 100.0 * u_mag / mag, "%", dist, dof,
                          source="type A", reference=record.method)
            out.append(combine(f"{name} magnitude", 0.0, "%", [(typea, 1.0)],
                               serial=record.serial).as_dict())
        if math.isfinite(u_phase):
            typea = Input("Type A", phase, u_phase, "deg", dist, dof, source="type A",
                          reference=record.method)
            out.append(combine(f"{name} phase", phase, "deg", [(typea, 1.0)],
                               serial=record.serial).as_dict())
    return out


def _reference_index(record, freqs) -> int:
    """The step of the deviations: the one the record's notes name, else the nearest 80 Hz."""
    from accelcal.methods.response.stepped import REFERENCE_FREQUENCY

    for note in record.notes:
        m = _REFERENCE.search(note)
        if m and m.group(1) in record.names:
            return record.names.index(m.group(1))
    return min(range(len(freqs)), key=lambda i: abs(math.log(freqs[i] / REFERENCE_FREQUENCY)))


def _deviation(b_i: dict | None, b_ref: dict | None, ratio: float):
    """``(u, nu_eff, k, U)`` of the deviation in %, from the two steps' magnitude budgets."""
    from accelcal.budget.gum import Input, combine

    if b_i is None or b_ref is None:
        return None
    terms = []
    for sign, b, where in ((1.0, b_i, "f"), (-1.0, b_ref, "f_ref")):
        for r in b["rows"]:
            if r["quantity"] in COMMON or not r["u"] > 0:
                continue
            terms.append((Input(f"{r['quantity']} ({where})", r["estimate"], r["u"],
                                r["unit"], r["distribution"], _inf(r["dof"]),
                                source=r.get("source", "")),
                          sign * ratio * r["sensitivity"]))
    if not terms:
        return 0.0, math.inf, 2.0, 0.0
    b = combine("deviation", 0.0, "%", terms)
    return b.u_c, b.nu_eff, b.k, b.U


def curve(rec, budgets_of) -> dict:
    """The certificate's points of one complex record (module docs), sorted by frequency."""
    from accelcal.methods.response.stepped import point_of

    pol = rec.polar()
    by_name = {b["coefficient"]: b for b in budgets_of}
    freqs, amps = [], []
    for name in rec.names:
        f, a = point_of(name) or (math.nan, None)
        freqs.append(f)
        amps.append(a)
    i_ref = _reference_index(rec, freqs)
    unit = rec.units.get(rec.names[0], "")
    b_ref = by_name.get(f"{rec.names[i_ref]} magnitude")
    points = []
    for i, name in enumerate(rec.names):
        mag = float(pol.magnitude[i])
        phase = math.degrees(float(pol.phase[i]))
        bm, bp = by_name.get(f"{name} magnitude"), by_name.get(f"{name} phase")
        if bm is None or bp is None:
            continue
        ratio = mag / float(pol.magnitude[i_ref])
        dev = (0.0, math.inf, 2.0, 0.0) if i == i_ref else _deviation(bm, b_ref, ratio)
        dev = dev or (None, None, None, None)
        points.append({
            "coefficient": name, "frequency_hz": freqs[i], "amplitude_g": amps[i],
            "unit": unit, "magnitude": mag, "magnitude_u": bm["u_c"] * mag / 100.0,
            "magnitude_U": bm["U"] * mag / 100.0, "magnitude_k": bm["k"],
            "magnitude_nu_eff": bm["nu_eff"],
            "deviation_pct": 100.0 * (ratio - 1.0), "deviation_db": 20.0 * math.log10(ratio),
            "deviation_u": dev[0], "deviation_U": dev[3], "deviation_k": dev[2],
            "deviation_nu_eff": None if dev[1] is None else _dof(dev[1]),
            "phase_deg": phase, "phase_u": bp["u_c"], "phase_U": bp["U"], "phase_k": bp["k"],
            "phase_nu_eff": bp["nu_eff"], "conformity": None})
    points.sort(key=lambda p: p["frequency_hz"])
    return {"method": rec.method, "route": ROUTES.get(rec.method, (rec.method, ""))[0],
            "unit": unit,
            "reference_frequency_hz": freqs[i_ref], "points": points}


def _fit_parameters(rec) -> tuple[tuple[str, ...], list[float], list[list[float]]]:
    """The fitted model's parameter names, values and covariance (the bandwidth left out)."""
    from accelcal.methods.response.model import BANDWIDTH

    keep = [i for i, n in enumerate(rec.names) if n != BANDWIDTH]
    names = tuple(rec.names[i] for i in keep)
    values = [float(rec.estimates[i]) for i in keep]
    cov = [[float(rec.covariance[i][j]) for j in keep] for i in keep]
    return names, values, cov


def _model_name(rec) -> str:
    for note in rec.notes:
        if note.startswith("transfer function "):
            return note.removeprefix("transfer function ")
    return "second-order"


def model(rec, lab, at) -> tuple[dict, list[dict]]:
    """A model-fit record's model, phases and group delays at ``at`` (Hz), and their budgets.

    Returns
    -------
    (dict, list of dict)
        ``{method, model, unit, parameters, at}`` (``at``: per frequency
        ``frequency_hz, phase_deg, phase_u, phase_U, phase_k,
        group_delay_s, group_delay_u, group_delay_U, group_delay_k``), and
        the budgets (:meth:`accelcal.budget.gum.Budget.as_dict`) of those
        phases and group delays, for the annex.
    """
    import numpy as np

    from accelcal.budget.gum import Input, combine
    from accelcal.methods.response.model import evaluate

    names, values, cov = _fit_parameters(rec)
    x, cov = np.asarray(values), np.asarray(cov)
    if not np.isfinite(cov).all():
        cov = np.where(np.isfinite(cov), cov, 0.0)

    def phase(p, f):
        return math.degrees(float(np.angle(evaluate(p, names, [f])[0])))

    def delay(p, f, h=1e-4):
        up, down = evaluate(p, names, [f * (1 + h), f * (1 - h)])
        return -float(np.angle(up / down)) / (2 * math.pi * 2 * f * h)  # -dphi/domega

    def spread(func):
        grad = np.zeros(x.size)
        for i in range(x.size):
            step = 1e-6 * max(abs(x[i]), 1e-9)
            up, down = x.copy(), x.copy()
            up[i] += step
            down[i] -= step
            grad[i] = (func(up) - func(down)) / (2 * step)
        return float(np.sqrt(max(grad @ cov @ grad, 0.0)))

    reference = lab.standards.get("reference_phase")
    rows, budgets = [], []
    for f in at:
        label = f"{f:g} Hz"
        fit_phase = Input("Type A (fit)", phase(x, f), spread(lambda p, f=f: phase(p, f)),
                          "deg", source="type A", reference=rec.method)
        terms = [(fit_phase, 1.0)]
        if reference is not None:
            terms.append((Input("reference_phase", reference.value_in("deg"),
                                reference.u_in("deg"), "deg", reference.distribution,
                                reference.dof, source="lab",
                                reference=reference.certificate), 1.0))
        bp = combine(f"phase at {label}", fit_phase.estimate, "deg", terms, serial=rec.serial)
        tau = delay(x, f)
        fit_delay = Input("Type A (fit)", tau, spread(lambda p, f=f: delay(p, f)), "s",
                          source="type A", reference=rec.method)
        bd = combine(f"group delay at {label}", tau, "s", [(fit_delay, 1.0)],
                     serial=rec.serial)
        budgets += [bp.as_dict(), bd.as_dict()]
        rows.append({"frequency_hz": float(f), "phase_deg": bp.estimate, "phase_u": bp.u_c,
                     "phase_U": bp.U, "phase_k": bp.k, "group_delay_s": tau,
                     "group_delay_u": bd.u_c, "group_delay_U": bd.U, "group_delay_k": bd.k})
    unit = rec.units.get("S0", "")
    return ({"method": rec.method, "model": _model_name(rec), "unit": unit,
             "parameters": dict(zip(names, values, strict=True)), "at": rows}, budgets)


def conformity(spec, rule, point: dict, *, serial: str, method: str, statements: dict):
    """The statement of conformity of one point's magnitude deviation (None: no band applies).

    A limit on ``magnitude deviation`` (:mod:`accelcal.conformity`) applies
    to the points inside its ``band_hz`` (every point without one);
    ``statements`` words each decision's outcome.
    """
    from accelcal.conformity import decide
    from accelcal.units import convert

    quantity = f"magnitude deviation at {point['frequency_hz']:g} Hz"
    if point["deviation_u"] is None:
        return None
    limits = [lim for lim in spec.limits_for(quantity, serial=serial, method=method)
              if lim.covers(point["frequency_hz"])]
    if not limits:
        return None
    lim = limits[0]
    value = float(convert(point["deviation_pct"], "%", lim.unit))
    u = float(convert(point["deviation_u"], "%", lim.unit))
    big_u = float(convert(point["deviation_U"], "%", lim.unit))
    dof = None if point["deviation_nu_eff"] == "inf" else point["deviation_nu_eff"]
    d = decide(value, u, dof, lim.lower, lim.upper, rule=rule,
               guard=big_u if lim.guard is None else lim.guard)
    return {"quantity": quantity, "estimate": value, "u": u, "U": big_u, "unit": lim.unit,
            "lower": lim.lower, "upper": lim.upper, "rule": rule, "guard": d.guard,
            "acceptance": list(d.acceptance), "outcome": d.outcome,
            "statement": statements[d.outcome], "conforming": d.conforming,
            "false_accept_risk": d.false_accept_risk}
