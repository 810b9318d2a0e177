"""The acceptance tests' measurement models for uncertainty budgets (:mod:`accelcal.budget`).

Each test's results are functions of the dwell means ``m_k`` (output unit,
read by the DAQ) and of the inputs the rig applied, which the record states
as told: the head's angle ``theta`` (``a = sin theta``, in units of the
local 1 g), the centrifuge's ``Omega^2 R`` or the coils' field ``B``
[IEEE1293]_ (DOMAIN section 12). The lab's inputs enter as follows; every
sensitivity is in closed form (:data:`INPUTS` lists each test's), except
the DAQ's linearity of the range and turn-on tests, a Kragten difference of
the reduction run again on the bowed outputs [Kragten1994]_ (0 on the count
of clipped samples, which has no uncertainty).

Threshold and resolution (``r_k = mean (m_(i+1) - m_i) / (K1 da_i)`` over
the steps of increment ``d_k``; the decided increment is a told ``d_j``):

- local gravity: every input is ``g / g_n`` of its told value, so the
  decided increment moves as ``+y / g`` and each response as ``-r / g``;
- the head's angle accuracy (one independent error per position): an
  increment between the positions ``theta_p`` and ``theta_q`` is off by
  ``cos theta_q e_q - cos theta_p e_p``: the decided increment has ``c =
  sqrt(cos^2 theta_p + cos^2 theta_q)`` (g per rad), a response ``r_k / d_k``
  times that;
- the DAQ's gain: ``c = r`` per relative gain on a response, 0 on the
  decided increment (the 50 % rule does not move for steps much above or
  below it); its linearity (the engine's bow ``v + l |v| v / max|v|`` of
  every sample) moves each dwell mean by ``l F_k / max|v|``, ``F_k`` the
  mean of ``|v| v`` over dwell k's samples, and ``r_k = w_k . m``, a linear
  form in the dwell means, by ``l w_k . F / max|v|``: ``c = w_k . F /
  max|v|``; its resolution (an independent quantization error of each
  dwell mean): ``c = ||w_k||`` per output unit.

Hysteresis (``H = (mean of the decreasing-leg means - mean of the
increasing-leg means) / K1`` at a point ``a = sin theta``):

- the head's repeatability (an independent angle error at each visit;
  its accuracy, the same at each visit, cancels): ``c = cos theta
  sqrt(1/n_d + 1/n_u)`` (g per rad), ``n_d, n_u`` the visits of each leg;
- the DAQ's gain ``c = H``; its linearity, as for the responses, ``c =
  (mean F_down - mean F_up) / (K1 max|v|)``; its resolution ``c =
  sqrt(1/n_d + 1/n_u) / K1`` (g per output unit).

Input range (the input where the nonlinearity relative to a straight line
fitted to the same dwells leaves the limit): a common scale error ``e`` of
every input scales the fitted line with it and leaves the nonlinearity
alone, so the range moves as ``(1 + e)``: on a centrifuge (``a = Omega^2 R
/ g_n``) ``c = y / R`` per metre of radius and ``c = 2 y`` per relative
rate error; in the gravity field (no input above 1 g) ``c = y / g``. The
DAQ's gain and offset leave the range alone (the line absorbs them); the
bias before and after the overload (``m / K1``) move by ``c = y`` per
relative gain and ``1 / K1`` per output unit of offset, their difference by
``c = y`` per relative gain.

Turn-on repeatability (bias ``b_j = beta_0 / beta_1`` at +-1 g of the local
gravity): local gravity ``c = y / g`` on every bias, its spread and the
drift (the scale factors, relative to their mean, do not move); the DAQ's
offset ``c = 1 / k_j`` (g per output unit) on each turn-on's bias and their
mean, and on their spread ``s`` only through the spread of the ``k_j``,
``c = sum (b_j - mean b)(1/k_j - mean 1/k) / ((N - 1) s)``; the sensor's temperature
by its bias temperature coefficient (:mod:`accelcal.budget.engine`, the
model's ``K0_T1``; on the spread this is a bound: a turn-on that ran
``u(T)`` away moves one bias by ``dK0/dT u(T)``).

Magnetic sensitivity (the slope of the output against the field over
``K1``): the coil constant's relative error ``e`` scales every field, so
``c = -m`` per relative error; the DAQ's gain ``c = m``.

:func:`rerun` runs a test's reduction again on a record perturbed in each
of these ways: the Kragten differences the tests check the closed forms by.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, threshold, resolution, hysteresis, input
   range, turn-on repeatability and magnetic sensitivity tests.
.. [Kragten1994] Kragten J., Analyst 119 (1994) 2161-2165 (the central
   differences of a re-run reduction).
"""

import math

from accelcal.errors import AccelcalError

_STEPS = ("local_gravity", "head_angle", "daq_gain", "daq_linearity", "daq_resolution")
INPUTS = {
    "threshold": _STEPS,
    "resolution": _STEPS,
    "hysteresis": ("head_repeatability", "daq_gain", "daq_linearity", "daq_resolution"),
    "range": ("centrifuge_radius", "centrifuge_rate", "daq_gain", "daq_offset",
              "daq_linearity"),
    "range in the gravity field": ("local_gravity", "daq_gain", "daq_offset", "daq_linearity"),
    "turn-on": ("local_gravity", "daq_offset", "daq_linearity", "sensor_temperature"),
    "magnetic": ("coil_constant", "daq_gain"),
}
"""The inputs of each test's model (a range test with no input above 1 g: in the gravity field)."""

GRAVITY_FIELD_G = 1.0 + 1e-9
"""Largest |input| (g) of a range test run in the gravity field (a head or tumble)."""


def _test(reduction) -> str:
    test = reduction.provenance.get("test") or reduction.method.partition("/")[2]
    if test == "range":
        inputs = reduction.observations.get("dwell_input")
        if inputs is not None and len(inputs) and max(abs(a) for a in inputs) <= GRAVITY_FIELD_G:
            return "range in the gravity field"
    return test


def inputs(reduction) -> tuple:
    """The lab inputs of this reduction's test (:data:`INPUTS`; every one for an unknown test)."""
    return INPUTS.get(_test(reduction), tuple(dict.fromkeys(q for t in INPUTS.values()
                                                              for q in t)))


def _to_row(row) -> float:
    """Size of one native unit of ``row`` (g, 1, g/mT, ...) in its budget's unit (ug, ...)."""
    if row.unit == row.native_unit:
        return 1.0
    from accelcal.units import convert

    try:
        return float(convert(1.0, row.native_unit, row.unit))
    except ValueError:
        return row.std / row.native_std if row.native_std else 1.0


def _index(name: str, prefix: str) -> int | None:
    """``k - 1`` of a row named ``prefix_k`` (None for another row)."""
    head, _, k = name.rpartition("_")
    return int(k) - 1 if head == prefix and k.isdigit() else None


def _per_output(std, output_unit: str) -> float:
    """Size of one lab unit of a voltage input in the record's output unit."""
    if output_unit not in ("V", "mV", "uV"):
        raise AccelcalError(f"not applicable to outputs in {output_unit}")
    return std.factor(output_unit)


def _gravity(exponent):
    """``c = p y / g`` per lab unit of local gravity, ``p = exponent(row)``."""

    def c(row, std):
        return exponent(row) * row.estimate / std.value_in("m/s^2") * std.factor("m/s^2")

    return c


def _relative(sign: float, rows=None):
    """``c = sign y`` per relative error (of the rows named in ``rows``; all when None)."""

    def c(row, std):
        if rows is not None and not rows(row.name):
            return 0.0
        per = std.factor("1") if std.dimension == "relative" else 1.0 / std.value
        return sign * row.estimate * per

    return c


def _steps(reduction, bows, full_scale: float) -> dict:
    """Closed forms of a threshold or resolution reduction (module docs)."""
    import numpy as np

    from accelcal.methods.acceptance.steps import weights

    obs, prov = reduction.observations, reduction.provenance
    test, k1, unit = prov["test"], prov["scale_factor"], prov["output_unit"]
    a = np.asarray(obs["dwell_input"])
    groups = []
    for size, idx, coef in weights(a, k1):
        where = np.unique(np.r_[a[idx], a[idx + 1]])
        groups.append((size, float(np.sqrt(np.sum(1.0 - where**2))),
                       float(np.sqrt(np.sum(coef**2))), float(coef @ bows)))
    decided = int(prov["decided"])

    def group(row):
        k = _index(row.name, "response")
        return None if k is None else groups[k]

    def angle(row, std):
        if row.name == test:
            return groups[decided][1] * _to_row(row) * std.factor("rad")
        g = group(row)
        return 0.0 if g is None else row.estimate / g[0] * g[1] * std.factor("rad")

    def linearity(row, std):
        g = group(row)
        return 0.0 if g is None else g[3] / full_scale * std.factor("1")

    def resolution(row, std):
        g = group(row)
        return 0.0 if g is None else g[2] * _per_output(std, unit)

    return _from_estimates(test) | {"head_angle": angle, "daq_linearity": linearity,
                                    "daq_resolution": resolution}


def _hysteresis(reduction, bows, full_scale: float) -> dict:
    """Closed forms of a hysteresis reduction (module docs)."""
    import numpy as np

    obs, prov = reduction.observations, reduction.provenance
    k1, unit = prov["scale_factor"], prov["output_unit"]
    a = np.asarray(obs["dwell_input"])
    direction = np.asarray(obs["dwell_direction"])
    points = []
    for p in prov["points_g"]:
        down, up = (a == p) & (direction < 0), (a == p) & (direction > 0)
        spread = math.sqrt(1.0 / down.sum() + 1.0 / up.sum())
        bow = (bows[down].mean() - bows[up].mean()) / k1
        points.append((math.sqrt(max(1.0 - p * p, 0.0)), spread, bow))

    def point(row):
        k = _index(row.name, "hysteresis")
        return points[k]

    return _from_estimates("hysteresis") | {
        "head_repeatability": lambda row, std: (point(row)[0] * point(row)[1] * _to_row(row)
                                                * std.factor("rad")),
        "daq_linearity": lambda row, std: (point(row)[2] / full_scale * _to_row(row)
                                           * std.factor("1")),
        "daq_resolution": lambda row, std: (point(row)[1] / k1 * _to_row(row)
                                            * _per_output(std, unit))}


_RANGES = ("range_pos", "range_neg")
_BIASES = ("bias_before", "bias_after")


def _radius(row, std):
    return row.estimate / std.value_in("m") * std.factor("m") if row.name in _RANGES else 0.0


def _rate(row, std):
    if std.dimension != "relative":
        raise AccelcalError("a rate in rad/s enters each input differently; declare the "
                        "rate's relative error (ppm)")
    return 2.0 * row.estimate * std.factor("1") if row.name in _RANGES else 0.0


def _from_estimates(test: str) -> dict:
    """The closed forms that need a test's results alone (not its dwells)."""
    response = lambda n: _index(n, "response") is not None  # noqa: E731
    if test in ("threshold", "resolution"):
        return {"local_gravity": _gravity(lambda r: 1 if r.name == test
                                          else -1 if response(r.name) else 0),
                "daq_gain": _relative(1.0, response)}
    if test.startswith("range"):
        return {"centrifuge_radius": _radius, "centrifuge_rate": _rate,
                "local_gravity": _gravity(lambda r: 1 if r.name in _RANGES else 0),
                "daq_gain": _relative(1.0, lambda n: n in (*_BIASES, "overload_shift"))}
    if test == "turn-on":
        return {"local_gravity": _gravity(
            lambda r: 1 if r.name in ("bias_repeatability", "drift", "bias_mean")
            or _index(r.name, "bias") is not None else 0)}
    if test == "magnetic":
        return {"coil_constant": _relative(-1.0), "daq_gain": _relative(1.0)}
    return {"daq_gain": _relative(1.0)} if test == "hysteresis" else {}


def _range(reduction) -> dict:
    """Closed forms of a range reduction (module docs)."""
    prov = reduction.provenance
    k1, unit = prov["scale_factor"], prov["output_unit"]

    def offset(row, std):
        return _to_row(row) / k1 * _per_output(std, unit) if row.name in _BIASES else 0.0

    return _from_estimates("range") | {"daq_offset": offset}


def _turn_on(reduction) -> dict:
    """Closed forms of a turn-on reduction (module docs)."""
    import numpy as np

    prov = reduction.provenance
    obs = reduction.observations
    inverse = 1.0 / np.asarray(obs["scale"], dtype=float)
    bias = np.asarray(obs["bias"], dtype=float)
    spread = float(np.std(bias, ddof=1))
    unit = prov["output_unit"]
    per = {"bias_mean": float(np.mean(inverse)),  # d s / d o of the spread s of b_j + o / k_j
           "bias_repeatability": float(np.sum((bias - bias.mean()) * (inverse - inverse.mean()))
                                       / ((bias.size - 1) * spread)) if spread else 0.0}

    def offset(row, std):
        k = _index(row.name, "bias")
        c = per.get(row.name, inverse[k] if k is not None else 0.0)
        return c * _to_row(row) * _per_output(std, unit) if c else 0.0

    return _from_estimates("turn-on") | {"daq_offset": offset}


def _linearity_rerun(run, skip=()):
    """The DAQ linearity's sensitivity by a Kragten difference of the re-run reduction.

    ``c = (y(l + u) - y(l - u)) / (2 u)`` per lab unit, computed once per
    declaration; the rows named in ``skip`` (a count) get 0.
    """
    cache = {}

    def c(row, std):
        if row.name in skip:
            return 0.0
        if run is None:
            raise AccelcalError("the input data were not found")
        step = std.u or 1.0
        if step not in cache:
            per = std.factor("1")
            cache[step] = (run(linearity=step * per), run(linearity=-step * per))
        plus, minus = cache[step]
        return (plus.value(row.name) - minus.value(row.name)) / (2.0 * step) * _to_row(row)

    return c


def _bows(record, reduction):
    """``F_k``, the mean of ``|v| v`` over each dwell's samples kept, and ``max|v|``.

    What the DAQ linearity's bow ``v + l |v| v / max|v|`` adds to each
    dwell mean, per ``l / max|v|``; without the record, ``|m| m`` of the
    dwell means and the largest ``|m|``.
    """
    from itertools import pairwise

    import numpy as np

    if record is None:
        m = np.asarray(reduction.observations["dwell_mean"])
        return np.abs(m) * m, float(np.abs(m).max())
    settle = float(reduction.assumed("settle", reduction.provenance.get("settle", 0.0)))
    v = np.asarray(record.output)
    bows = [(np.abs(v[lo:hi]) * v[lo:hi])[record.t[lo:hi] >= record.t[lo] + settle].mean()
            for lo, hi in pairwise(record.dwells())]
    return np.asarray(bows), float(np.abs(v).max())


def _record(records):
    """The step record (read from its file) of ``records``, or None."""
    if isinstance(records, list | tuple):  # the input files a calibration record names
        records = records[0] if records else None
    if records is None or hasattr(records, "dwells"):
        return records
    from accelcal.io.formats import acceptance as steps_format

    return steps_format.read(records)


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of an acceptance reduction.

    The closed forms (module docs) need the reduction only; ``records``
    (the step record or its file, or the files a calibration record names)
    adds the re-run the DAQ's linearity takes on the range and turn-on
    tests, and the full scale ``max|v|`` of the linearity's bow (else the
    largest dwell mean).

    A reduction without the dwells it was made from (a calibration record
    whose data are not found) gets the closed forms that need its results
    alone (local gravity, the centrifuge, the coils, the DAQ's gain); the
    other inputs are then left out, noted.
    """
    from accelcal.budget.engine import DataModel

    record = _record(records)
    test = _test(reduction)
    obs = reduction.observations
    need = "scale" if test == "turn-on" else "dwell_mean"
    unit = reduction.provenance.get("output_unit", "V")
    if need not in obs:  # a calibration record without its data: its results alone
        return DataModel(None, 0, unit, analytic=_from_estimates(test))
    if test in ("threshold", "resolution"):
        analytic = _steps(reduction, *_bows(record, reduction))
    elif test == "hysteresis":
        analytic = _hysteresis(reduction, *_bows(record, reduction))
    elif test.startswith("range"):
        analytic = _range(reduction)
    elif test == "turn-on":
        analytic = _turn_on(reduction)
    else:
        analytic = _from_estimates(test)
    run = rerun(record, reduction) if record is not None else None
    if test.startswith("range") or test == "turn-on":
        analytic["daq_linearity"] = _linearity_rerun(run, ("clipped_samples",))
    return DataModel(run, 0, unit, analytic=analytic)


def rerun(record, reduction):
    """The reduction of ``record`` perturbed, with the settings of ``reduction``.

    Returns
    -------
    callable
        ``run(*, gain=0.0, offset=0.0, linearity=0.0, input_scale=0.0,
        angles=None, visits=None, dwell_offsets=None, field_scale=0.0) ->
        Reduction``: the outputs ``v`` become ``bowed((1 + gain) v + offset,
        linearity)`` (:func:`accelcal.budget.engine.bowed`), plus
        ``dwell_offsets[k]`` (output unit) and ``K1 cos theta_k visits[k]``
        (an angle error of each visit, rad) on dwell ``k``'s samples; the told
        inputs become ``(1 + input_scale) a``, and ``sin(theta_p +
        angles[p])`` at each position ``p`` (the distinct dwell inputs,
        ascending); the field ``(1 + field_scale) B``. A range test's
        ``linear_span`` scales with the inputs (the line keeps its dwells).
    """
    import dataclasses

    import numpy as np

    from accelcal.budget.engine import bowed
    from accelcal.methods.acceptance import reduce

    prov = reduction.provenance
    options = {"settle": float(reduction.assumed("settle", prov.get("settle", 0.0)))}
    if prov.get("test") == "range":
        options |= {"limit": prov["limit"], "linear_span": reduction.assumed("linear_span")}
    elif "max_error" in prov:
        options |= {"max_error": prov["max_error"], "target": prov["target"]}
    edges = record.dwells()
    counts = np.diff(edges)
    starts = record.input[edges[:-1]]
    positions, where = np.unique(record.input, return_inverse=True)

    def run(*, gain=0.0, offset=0.0, linearity=0.0, input_scale=0.0, angles=None, visits=None,
            dwell_offsets=None, field_scale=0.0):
        out = bowed(np.asarray(record.output) * (1.0 + gain) + offset, linearity)
        if dwell_offsets is not None:
            out = out + np.repeat(dwell_offsets, counts)
        if visits is not None:
            cos = np.sqrt(np.clip(1.0 - starts**2, 0.0, None))
            out = out + np.repeat(record.scale_factor * cos * np.asarray(visits), counts)
        applied = np.asarray(record.input)
        if angles is not None:
            applied = np.sin(np.arcsin(np.clip(positions, -1.0, 1.0)) + angles)[where]
        applied = applied * (1.0 + input_scale)
        field = None if record.field is None else record.field * (1.0 + field_scale)
        moved = dataclasses.replace(record, output=out, input=applied, field=field)
        span = options.get("linear_span")
        scaled = {} if span is None else {"linear_span": span * (1.0 + input_scale)}
        return reduce(moved, **(options | scaled))  # the same dwells on the line

    return run
