"""Acceptance tests of pendulous accelerometers: threshold, resolution, hysteresis, range, etc.

The tests of a specification that are not calibration coefficients (IEEE
1293, IEEE 337), on the indexing head. The package:

:mod:`~accelcal.methods.acceptance.dwells`
    :func:`dwell_means`: the output at each dwell with its standard error.
:mod:`~accelcal.methods.acceptance.steps`
    :func:`reduce_steps`: threshold (at null) and resolution (at a set
    point) by the 50 % rule, the probability that the decision is wrong
    and the dwell that makes it reliable.
:mod:`~accelcal.methods.acceptance.hysteresis`
    :func:`reduce_hysteresis`: decreasing minus increasing leg at each
    input point of the cycle 0 -> +1 g -> 0 -> -1 g -> 0.
:mod:`~accelcal.methods.acceptance.range`
    :func:`reduce_range`: the input where the nonlinearity leaves a limit,
    clipped samples, the bias before and after the overload.
:mod:`~accelcal.methods.acceptance.turnon`
    :func:`reduce_turn_on`: bias and scale-factor repeatability from
    turn-on to turn-on, in-run drift.
:mod:`~accelcal.methods.acceptance.environment`
    :func:`~accelcal.methods.acceptance.environment.simulate_pair`: two
    simulated calibration records of a serial around an environment.
:mod:`~accelcal.methods.acceptance.magnetic`
    :func:`reduce_magnetic`: the output change per mT of a field along
    each axis (Helmholtz coils), a least-squares slope per axis.
:mod:`~accelcal.methods.acceptance.records`
    :func:`repeatability` over several calibration records of a serial,
    :func:`compare` of two (the shift, E_n, z or Welch t).
:mod:`~accelcal.methods.acceptance.figures`
    :func:`figures`: the step response with the 50 % line, the hysteresis
    loop, the range curve with clipping marked, the repeatability chart.

The rig simulators are :mod:`accelcal.rigs.acceptance` (indexing head) and
and :mod:`accelcal.rigs.acceptance_runs` (centrifuge, turn-ons),
:mod:`accelcal.rigs.acceptance_env` (before/after an environment, Helmholtz
coils), the record format
:mod:`accelcal.io.formats.acceptance` (kind ``steps``). The verbs:
:func:`simulate` (the rig) and :func:`reduce` (a record, or its file, to a
Reduction: what ``accelcal acceptance reduce`` does); :func:`quantity_rows`
gives that command's rows.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, IEEE Specification Format Guide and Test
   Procedure for Linear Single-Axis, Nongyroscopic Accelerometers.
.. [DOMAIN] accelcal domain notes, section 12.
"""

from accelcal.methods import ReportText
from accelcal.methods.acceptance.dwells import Dwells, dwell_means
from accelcal.methods.acceptance.figures import figures
from accelcal.methods.acceptance.hysteresis import reduce_hysteresis
from accelcal.methods.acceptance.magnetic import AXIS_LABELS, reduce_magnetic
from accelcal.methods.acceptance.range import reduce_range
from accelcal.methods.acceptance.records import compare, repeatability
from accelcal.methods.acceptance.steps import FAMILY, MAX_ERROR, RULE, TARGET, reduce_steps
from accelcal.methods.acceptance.turnon import reduce_turn_on

__all__ = [
    "ERRATA", "FAMILY", "MAX_ERROR", "RULE", "TARGET", "Dwells", "compare", "dwell_means",
    "figures", "from_inputs", "quantity_rows", "reduce", "reduce_hysteresis", "reduce_magnetic",
    "reduce_range",
    "reduce_steps", "reduce_turn_on", "repeatability", "report_text", "simulate",
]

ERRATA = ()
"""No departures from the standards' definitions (docs/acceptance.md)."""


def report_text(reduction) -> ReportText:
    """The report's title and summary of an acceptance reduction."""
    prov = reduction.provenance
    test = prov.get("test", "")
    if test == "range":
        summary = ("A ladder of inputs up to and past full scale on both sides, at rest before "
                   "and after: the input range is where the nonlinearity leaves "
                   f"{prov.get('limit', 0.0):g} of the input; clipped samples counted; the "
                   "bias before and after the overload.")
    elif test == "turn-on":
        summary = (f"{prov.get('turn_ons', 0)} turn-ons, each with dwells at +1 g and -1 g: "
                   "bias, scale factor and in-run drift per turn-on; their spread from turn-on "
                   "to turn-on with 95 % chi-square intervals.")
    elif test == "magnetic":
        summary = ("Helmholtz coils step a uniform field along the IA, PA and OA in turn: the "
                   "magnetic sensitivity per axis is the least-squares slope of the dwell means "
                   "against the field over the scale factor, in ug/mT.")
    elif test == "hysteresis":
        summary = (f"Input cycle 0 → +1 g → 0 → −1 g → 0 on the indexing head; the hysteresis at "
                   f"each of {len(prov.get('points_g', []))} input points is the decreasing-leg "
                   "minus the increasing-leg dwell mean over the scale factor.")
    else:
        summary = (f"Input stepped about {prov.get('set_point_g', 0.0):.3g} g by a ladder of "
                   f"{len(prov.get('sizes_g', []))} increments, each applied and reversed; the "
                   f"{test} is the smallest increment whose output change reaches 50 % of the "
                   "predicted change, with the probability that the decision is wrong.")
    return ReportText(title=f"Acceptance test: {test}", summary=summary,
                      sensor_summary="Dwell means with pooled white-noise standard errors.",
                      paper="IEEE1293")


def simulate(test: str = "threshold", *, seed=None, **settings):
    """A simulated step test from the rigs.

    :func:`accelcal.rigs.acceptance.simulate` for a threshold, resolution or
    hysteresis test, :func:`~accelcal.rigs.acceptance_runs.simulate_range`
    and :func:`~accelcal.rigs.acceptance_runs.simulate_turn_on`,
    :func:`~accelcal.rigs.acceptance_env.simulate_magnetic` for the others.
    """
    from accelcal.rigs import acceptance_runs
    from accelcal.rigs.acceptance import simulate as rig_simulate

    if test == "magnetic":
        from accelcal.rigs.acceptance_env import simulate_magnetic

        return simulate_magnetic(seed=seed, **settings)
    if test == "range":
        return acceptance_runs.simulate_range(seed=seed, **settings)
    if test == "turn-on":
        return acceptance_runs.simulate_turn_on(seed=seed, **settings)
    return rig_simulate(test, seed=seed, **settings)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`).

    The step record the record names, reduced with the command's defaults.
    """
    from accelcal.method_ids import canonical

    if not canonical(record.method).startswith(f"{FAMILY}/") or not files:
        return []
    return [(reduce(files[0]), {})]


def reduce(records, *, test: str | None = None, settle: float = 0.0,
           max_error: float = MAX_ERROR, target: float = TARGET, limit: float | None = None,
           linear_span: float | None = None):
    """Reduce a step record (or its file), as ``accelcal acceptance reduce`` does.

    ``test`` (optional) must be the record's own; ``settle``, ``max_error``
    and ``target`` as :func:`reduce_steps` takes them (the hysteresis and
    turn-on use ``settle`` only); ``limit`` and ``linear_span`` as
    :func:`reduce_range` takes them.
    """
    from os import PathLike

    from accelcal.errors import AccelcalError

    record = records
    if isinstance(records, str | PathLike):
        from accelcal.io.formats import acceptance as steps_format

        record = steps_format.read(records)
    if test is not None and test != record.test:
        raise AccelcalError(f"the record holds a {record.test} test, not {test}",
                            parameter="test")
    if record.test == "hysteresis":
        return reduce_hysteresis(record, settle=settle)
    if record.test == "range":
        from accelcal.methods.acceptance.range import LIMIT

        return reduce_range(record, settle=settle, limit=LIMIT if limit is None else limit,
                            linear_span=linear_span)
    if record.test == "turn-on":
        return reduce_turn_on(record, settle=settle)
    if record.test == "magnetic":
        return reduce_magnetic(record, settle=settle)
    return reduce_steps(record, settle=settle, max_error=max_error, target=target)


def quantity_rows(reduction) -> list[dict]:
    """Rows ``quantity, estimate, std, unit``: accelerations in ug, responses as fractions.

    A magnetic test's sensitivities are in ug/mT. A resolution also gets
    ``resolution / input`` (ppm of the set point's input); a range test
    states the input range in g; a turn-on test's rows also have ``low``
    and ``high``, the 95 % interval of a standard deviation.
    """
    est, prov = reduction.estimate, reduction.provenance
    if prov.get("test") in _LABELS:
        return _run_rows(reduction)
    rows = []
    for name, value, std in zip(est.names, est.values, est.std, strict=True):
        unit = est.units[name]
        label = name
        if name.startswith("response_"):
            label = f"response to {prov['sizes_g'][int(name[9:]) - 1] * 1e6:.4g} ug"
        elif name.startswith("hysteresis_"):
            label = f"hysteresis at {prov['points_g'][int(name[11:]) - 1]:+.4g} g"
        elif name in AXIS_LABELS:
            label = f"magnetic sensitivity {AXIS_LABELS[name]}"
        factor = 1e6 if unit in ("g", "g/mT") else 1.0
        rows.append({"quantity": label, "estimate": float(value) * factor,
                     "std": float(std) * factor, "unit": "u" + unit if factor != 1.0 else unit})
    a0 = abs(prov.get("set_point_g", 0.0))
    if prov.get("test") == "resolution" and a0 > 0:
        rows.insert(1, {"quantity": "resolution / input", "unit": "ppm",
                        "estimate": reduction.value("resolution") / a0 * 1e6,
                        "std": reduction.std("resolution") / a0 * 1e6})
    return rows


_LABELS = {
    "range": {"range_pos": ("input range (+)", 1.0, "g"),
              "range_neg": ("input range (-)", 1.0, "g"),
              "clipped_samples": ("clipped samples", 1.0, "1"),
              "bias_before": ("bias before overload", 1e6, "ug"),
              "bias_after": ("bias after overload", 1e6, "ug"),
              "overload_shift": ("overload bias shift", 1e6, "ug")},
    "turn-on": {"bias_repeatability": ("bias repeatability", 1e6, "ug"),
                "scale_repeatability": ("scale-factor repeatability", 1e6, "ppm"),
                "drift": ("bias drift", 1e6 * 3600.0, "ug/h"),
                "bias_mean": ("mean bias", 1e6, "ug")},
}
"""Row label, factor and unit of each coefficient of a range or turn-on reduction."""


def _run_rows(reduction) -> list[dict]:
    """:func:`quantity_rows` of a range or turn-on reduction."""
    import math

    est, prov = reduction.estimate, reduction.provenance
    labels = _LABELS[prov["test"]]
    intervals = {"bias_repeatability": (prov.get("bias_interval_g"), 1e6),
                 "scale_repeatability": (prov.get("scale_interval"), 1e6)}
    rows = []
    for name, value, std in zip(est.names, est.values, est.std, strict=True):
        kind, _, k = name.rpartition("_")
        if name in labels:
            label, factor, unit = labels[name]
        elif kind == "bias":
            label, factor, unit = f"bias at turn-on {k}", 1e6, "ug"
        else:
            label, factor, unit = f"scale factor at turn-on {k}", 1e6, "ppm"
        row = {"quantity": label, "estimate": float(value) * factor,
               "std": float(std) * factor, "unit": unit}
        if prov["test"] == "turn-on":
            interval, f = intervals.get(name, (None, 1.0))
            row["low"], row["high"] = ((interval[0] * f, interval[1] * f) if interval
                                       else (math.nan, math.nan))
        rows.append(row)
    return rows
