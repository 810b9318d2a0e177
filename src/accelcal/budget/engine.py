"""Itemised budgets: a reduction's Type A part, its priors and the lab's inputs per coefficient.

For each reported coefficient (each sensor's row of
:meth:`~accelcal.results.Reduction.rows`, in its engineering unit: µg, ppm,
µrad, µg/g², ... of :mod:`accelcal.engineering`) the budget holds

- the Type A part: the reduction's variance less its Type B parts, with the
  reduction's degrees of freedom (infinite when the noise was given);
- one row per prior of an unestimated term (:attr:`Reduction.type_b`);
- one row per input the method's measurement model has and the lab file
  declares (the method's ``budget`` module, :data:`Method.budget_inputs`).

Sensitivity coefficients of inputs that enter through the data (the DAQ's
gain, offset and linearity, the load resistor, each position's angle) are
found by re-running the method's own reduction on perturbed data, by
central differences with the step ``u(x_i)`` (Kragten [Kragten1994]_):
``c_i = (y(x_i + u_i) - y(x_i - u_i)) / (2 u_i)``. A vector input (one
independent error per position, e.g. the head's angle accuracy) is
perturbed one position at a time; its row's sensitivity is the
root-sum-square of the per-position ones (each position's error
independent, same ``u``). Inputs that enter through the reduction's
parameters or the sensor's known coefficients are analytic:

- local gravity ``g``: a coefficient of order ``n`` in specific force,
  referred to the 1 g of the test, scales as ``g^(1-n)`` (bias ``+1``,
  scale factor in output unit per g ``-1``, misalignment 0, K2 ``-1``, K3
  ``-2``, K4 ``-3``), so ``c = (1 - n) y / g``: for the scale factor
  ``u(K1)/K1 = u(g)/g`` [GUM]_ 5.1.3;
- the sensor's temperature ``T``: ``c = dy/dT``, the sensor's temperature
  coefficients (of the ``model`` given, or the reduction's) at the lab's
  temperature;
- the tilt of the head's axis ``beta``: a gravity component ``beta`` along
  the rotation axis, entering the bias through the sensor's misalignment
  toward that axis; the in-plane ``cos beta`` is of second order.

References
----------
.. [Kragten1994] Kragten J., Calculating standard deviations and confidence
   intervals with a universally applicable spreadsheet technique, Analyst
   119 (1994) 2161-2165.
.. [GUM] JCGM 100:2008, secs. 5.1, G.4.
"""

import math
from dataclasses import dataclass, field

from accelcal.budget.gum import Input, combine
from accelcal.errors import AccelcalError

ORDER_EXPONENT = {"bias": 1, "scale": -1, "ratio": 0, "misalignment": 0, "transverse": 0,
                  "second": -1, "third": -2, "fourth": -3}
"""Exponent ``p`` of ``g`` in each quantity's coefficient (``y ~ g^p``, the test's 1 g)."""

NO_MODEL = "no lab inputs modelled for this method"

CORRECTIONS = ("head_angle", "head_repeatability", "head_axis_tilt", "autocollimator",
               "daq_gain", "daq_offset", "daq_linearity", "daq_resolution", "load_resistor",
               "centrifuge_rate", "frequency", "reference_phase", "daq_gain_mismatch",
               "daq_delay_mismatch", "transverse_motion", "relative_motion")
"""Inputs whose value is an error (zero when none is known): a non-zero value is a
correction, which the budget names but does not apply."""


@dataclass
class DataModel:
    """How a method's data can be perturbed and reduced again (a method's ``budget`` module).

    Attributes
    ----------
    reduce : callable or None
        ``reduce(*, gain=0.0, offset=0.0, linearity=0.0, angles=None) -> Reduction``:
        the method's reduction of its data with the outputs multiplied by
        ``1 + gain``, shifted by ``offset`` (output unit), bowed by
        ``linearity`` (relative at full scale: ``v + linearity |v| v / max|v|``)
        and the positions shifted by ``angles`` (rad, one per position); a
        method takes the keywords its data have (and those of
        ``parameters``). None: the data are not at hand (closed forms only).
    n_positions : int
    output_unit : str
    rotation_axis : str
        ``"OA"`` or ``"PA"`` (the axis the head's tilt puts gravity along).
    vectors : dict
        Per-position inputs -> the keyword of ``reduce`` they perturb (rad,
        one per position); absent ones perturb ``angles``.
    analytic : dict
        Inputs whose sensitivity the method states in closed form:
        ``quantity -> f(reported, standard)``, the coefficient of one
        :class:`Reported` per unit of the standard (an
        :class:`~accelcal.errors.AccelcalError` from it: the declaration
        does not enter the model, noted).
    per_row : dict
        Inputs whose standard or closed-form coefficient depends on the
        row and on the lab's other inputs: ``quantity -> f(reported,
        standard, lab) -> (Standard, c)``, the standard as it applies to
        the row (e.g. a reference's certificate interpolated at the row's
        frequency) and the coefficient per unit of it; a string instead
        says why the input is not in the budget.
    parameters : dict
        Inputs that enter through the reduction's parameters, perturbed
        and re-run rather than analytic: ``quantity -> {dimension:
        (keyword, unit)}``, the keyword of ``reduce`` taking a shift in
        ``unit`` for a lab value of that dimension (``"/value"``: a relative
        shift, the lab's uncertainty over its value).
    """

    reduce: object
    n_positions: int
    output_unit: str = "V"
    rotation_axis: str = "OA"
    vectors: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    analytic: dict = field(default_factory=dict)
    per_row: dict = field(default_factory=dict)


@dataclass
class Reported:
    """One reported coefficient (or part of a complex one) that gets a budget.

    Attributes
    ----------
    sensor : int
    name, label : str
        Its plain and reported names.
    kind : str or None
        Its quantity (:data:`accelcal.engineering.QUANTITIES`: ``bias``,
        ``scale``, ...).
    unit, estimate, std :
        The budget's unit, estimate and standard uncertainty.
    native_std, native_unit :
        The reduction's own.
    base : float
        The reduction's estimate (of the magnitude, for a complex one).
    relative : float
        ``1e6`` (ppm) or ``100`` (%) when the budget is relative to ``base``.
    part : str
        ``"magnitude"`` or ``"phase"`` of a complex coefficient, else ``""``.
    place : int
        Its index in :meth:`Reduction.rows`.
    """

    sensor: int
    name: str
    label: str
    kind: str | None
    unit: str
    estimate: float
    std: float
    native_std: float
    native_unit: str
    base: float
    relative: float = 0.0
    part: str = ""
    place: int = -1

    @property
    def title(self) -> str:
        """The budget's name: the coefficient's, with the part of a complex one."""
        return f"{self.label} {self.part}" if self.part else self.label


def _eng_kind(reduction, label: str, plain: str) -> str | None:
    from accelcal.engineering import QUANTITIES

    kind = reduction.quantities.get(plain) or QUANTITIES.get(plain)
    return kind.split("/", 1)[0] if kind else None


def _rows(reduction) -> list[Reported]:
    out = []
    names = list(reduction.sensor_names)
    for place, r in enumerate(reduction.rows(engineering=True)):
        start = len(out)
        _row_of(reduction, r, names, out)
        for row in out[start:]:
            row.place = place
    return out


def _row_of(reduction, r, names, out) -> None:
    """Append the budget rows of one reduction row to ``out``."""
    if r.get("status") != "fitted":
        return
    if "real" in r:  # a complex coefficient: its magnitude (in %) and phase (deg)
        out += _complex_rows(r, names.index(r["sensor"]))
        return
    est, std = r["estimate"], r["std"]
    if not (isinstance(est, float | int) and math.isfinite(est) and math.isfinite(std)):
        return
    sensor = names.index(r["sensor"])
    plain = r.get("plain", r["coefficient"])
    kind = _eng_kind(reduction, r["coefficient"], plain)
    if "eng_unit" in r and math.isfinite(r["eng_std"]) and math.isfinite(r["eng_estimate"]):
        out.append(Reported(sensor, plain, r["coefficient"], kind, r["eng_unit"],
                        r["eng_estimate"], r["eng_std"], std, r["unit"], est))
    elif kind == "scale" and est:
        out.append(Reported(sensor, plain, r["coefficient"], kind, "ppm", 0.0,
                        std / abs(est) * 1e6, std, r["unit"], est, relative=1e6))
    else:
        out.append(Reported(sensor, plain, r["coefficient"], kind, r["unit"], est, std, std,
                        r["unit"], est))


def _complex_rows(r, sensor: int) -> list[Reported]:
    mag, mag_std = r["magnitude"], r["magnitude_std"]
    phase, phase_std = r["phase_deg"], r["phase_std_deg"]
    out = []
    if mag and math.isfinite(mag) and math.isfinite(mag_std):
        out.append(Reported(sensor, r["coefficient"], r["coefficient"], None, "%", 0.0,
                        mag_std / abs(mag) * 100.0, mag_std, r["unit"], mag, relative=100.0,
                        part="magnitude"))
    if math.isfinite(phase) and math.isfinite(phase_std):
        out.append(Reported(sensor, r["coefficient"], r["coefficient"], None, "deg", phase,
                        phase_std, phase_std, "deg", phase, part="phase"))
    return out


def _values(reduction, rows: list[Reported]) -> list[float]:
    """The engineering value of each of ``rows`` in a (re-run) reduction.

    Rows are matched by sensor and name, else by their place among the
    sensor's rows (a name that carries a perturbed input, e.g. a step's
    frequency).
    """
    listed = reduction.rows(engineering=True)
    table = {(r["sensor"], r["coefficient"]): r for r in listed}
    names = reduction.sensor_names
    out = []
    for row in rows:
        r = table.get((names[row.sensor], row.label))
        if r is None and row.place < len(listed) and listed[row.place]["sensor"] == names[
                row.sensor]:
            r = listed[row.place]
        if r is None:
            out.append(math.nan)
        elif row.part == "magnitude":
            out.append((r["magnitude"] / row.base - 1.0) * row.relative)
        elif row.part == "phase":
            out.append(r["phase_deg"])
        elif row.unit == r.get("eng_unit"):
            out.append(r["eng_estimate"])
        elif row.relative:
            out.append((r["estimate"] / row.base - 1.0) * row.relative)
        else:
            out.append(r["estimate"])
    return out


def _run(model: DataModel, rows, **shift) -> list[float]:
    """The rows' values in the reduction of the perturbed data (NaN where it fails)."""
    import numpy as np

    try:
        return _values(model.reduce(**shift), rows)
    except (AccelcalError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return [math.nan] * len(rows)


def _kragten(model: DataModel, rows, key: str, step: float, per_unit: float) -> list[float]:
    """Central differences of every row for a perturbation ``key`` of ``step`` (lab unit)."""
    plus = _run(model, rows, **{key: step * per_unit})
    minus = _run(model, rows, **{key: -step * per_unit})
    return [(p - m) / (2.0 * step) for p, m in zip(plus, minus, strict=True)]


def per_position(model: DataModel, rows, step_rad: float, key: str = "angles"):
    """Sensitivities of every row to each position's error, per radian: shape (rows, positions).

    Central differences with ``step_rad``, one position at a time.
    """
    import numpy as np

    out = np.zeros((len(rows), model.n_positions))
    for i in range(model.n_positions):
        shift = np.zeros(model.n_positions)
        shift[i] = step_rad
        plus = np.array(_run(model, rows, **{key: shift}))
        minus = np.array(_run(model, rows, **{key: -shift}))
        out[:, i] = (plus - minus) / (2.0 * step_rad)
    return out


def temperature_polynomial(row: Reported, model):
    """The sensor's temperature terms of a coefficient: ``(reference, {k: c_k}, scale)`` or None.

    The coefficient moves by ``scale * sum_k c_k (T - reference)^k``
    (``k = 1, 2, 3``; ``scale`` 1e6 for a budget in µg, ppm, µrad or
    µg/g²); None when the model has no temperature terms or the quantity
    none that apply.
    """
    terms = getattr(model, "temperature", None)
    if terms is None or row.kind not in ("bias", "scale", "ratio", "misalignment", "second"):
        return None
    base = {"bias": "K0", "scale": "K1", "ratio": "K1", "second": "K2"}.get(row.kind)
    if row.kind == "misalignment":
        base = "Kp" if row.name.lower().endswith("p") else "Ko"
    coefficients = dict(terms.coefficients)
    scale = 1e6 if row.unit in ("ug", "ppm", "urad", "ug/g^2") else 1.0
    return terms.reference, {k: coefficients.get(f"{base}_T{k}", 0.0) for k in (1, 2, 3)}, scale


def _temperature_slope(row: Reported, model, temperature: float) -> float | None:
    """``dy/dT`` of a coefficient from the sensor's temperature terms (None: none apply)."""
    found = temperature_polynomial(row, model)
    if found is None:
        return None
    reference, c, scale = found
    dt = temperature - reference
    return scale * sum(k * c[k] * dt ** (k - 1) for k in c)


def _prior_of(reduction, name: str):
    """The reduction's prior behind a contribution's input (``K0_asym@90deg[U2]``: ``K0_asym``)."""
    plain = name.split("[", 1)[0].split("@", 1)[0]
    return next((p for p in reduction.priors if p.name in (name, plain)), None)


def _lab_input(std, components=()) -> Input:
    return Input(std.quantity, std.value, std.u, std.unit, std.distribution, std.dof, "lab",
                 std.certificate, tuple(components))


def _gravity(rows, std) -> list[float]:
    g = std.value_in("m/s^2")
    per = std.value / g  # lab unit per m/s^2
    out = []
    for row in rows:
        p = ORDER_EXPONENT.get(row.kind or "", 0)
        if row.kind == "scale":  # ppm deviation: d/dg of (K1/nominal - 1) 1e6
            value = (row.estimate * 1e-6 + 1.0) * 1e6
            out.append(p * value / g / per)
        else:
            out.append(p * row.estimate / g / per)
    return out


def sensitivities(reduction, lab, data_model: DataModel | None, inputs, *, model=None,
                  notes: list | None = None) -> tuple[list, dict, dict]:
    """The budget rows of a reduction and their sensitivity to every declared input.

    ``inputs`` are the method's input quantities; those the lab declares
    and the model can evaluate get a column; ``notes`` collects why others
    do not.

    Returns
    -------
    rows : list
        One per reported coefficient (and part of a complex one).
    columns : dict
        ``quantity -> [c per row]``, result unit per lab unit.
    components : dict
        ``quantity -> [per-position sensitivities per row]`` of the vector
        inputs (their column is the root-sum-square).
    """
    notes = [] if notes is None else notes
    rows = _rows(reduction)
    out = {}
    declared = [q for q in inputs if q in lab.standards]
    current = data_model is not None and data_model.output_unit == "mA"
    gain = None
    vectors, components = {}, {}
    for q in declared:
        std = lab.standards[q]
        if q in CORRECTIONS and std.value != 0 and (std.dimension == "relative" or q not in (
                "centrifuge_rate", "frequency", "load_resistor")):
            notes.append(f"{q}: the declared value {std.value:g} {std.unit} is a correction "
                         "the reduction has not applied; only its uncertainty is in the budget")
        if data_model is not None and q in data_model.per_row:
            each = [data_model.per_row[q](r, std, lab) for r in rows]
            why = next((e for e in each if isinstance(e, str)), None)
            if why is not None:
                notes.append(f"{q}: {why}; not in the budget")
                continue
            out[q] = [c for _, c in each]
        elif data_model is not None and q in data_model.analytic:
            try:
                out[q] = [data_model.analytic[q](r, std) for r in rows]
            except AccelcalError as exc:  # the closed form does not take this declaration
                notes.append(f"{q}: {exc.message}; not in the budget")
        elif data_model is not None and data_model.reduce and q in data_model.parameters:
            keyword = data_model.parameters[q].get(std.dimension)
            if keyword is None:
                notes.append(f"{q}: a value in {std.unit} does not enter this model; not in "
                             "the budget")
                continue
            per = (1.0 / std.value if keyword[1] == "/value" and std.value else
                   std.factor(keyword[1]))  # "/value": a relative error of the value
            out[q] = _kragten(data_model, rows, keyword[0], std.u or 1.0, per)
        elif q == "local_gravity":
            out[q] = _gravity(rows, std)
            unknown = sorted({r.label for r in rows if r.kind is None})
            if unknown:
                notes.append("local_gravity: taken as not entering " + ", ".join(unknown)
                             + " (no engineering quantity, no input data to re-run)")
        elif q == "sensor_temperature":
            slopes = [_temperature_slope(r, model or reduction.models[r.sensor],
                                         std.value_in("degC")) for r in rows]
            if all(s is None for s in slopes):
                notes.append("sensor_temperature: the sensor's temperature coefficients are "
                             "not known (give a model with temperature terms: --model); not "
                             "in the budget")
                continue
            out[q] = [s or 0.0 for s in slopes]
        elif data_model is None or data_model.reduce is None:
            notes.append(f"{q}: the input data were not found; not in the budget")
        elif q in ("daq_gain", "daq_linearity"):
            per = std.factor("1")  # lab unit -> relative
            key = "gain" if q == "daq_gain" else "linearity"
            out[q] = _kragten(data_model, rows, key, std.u or 1.0, per)
            if q == "daq_gain":
                gain = [c / per for c in out[q]]
        elif q == "daq_offset":
            if data_model.output_unit not in ("V", "mV"):
                notes.append(f"daq_offset: not applicable to outputs in {data_model.output_unit}")
                continue
            per = std.u_in(data_model.output_unit) / std.u if std.u else 1.0
            out[q] = _kragten(data_model, rows, "offset", std.u or 1.0, per)
        elif q in ("load_resistor", "load_resistor_tc"):
            if not current:
                notes.append(f"{q}: not applicable to a voltage output")
                continue
            if gain is None:  # per relative gain
                gain = _kragten(data_model, rows, "gain", 1e-6, 1.0)
            if q == "load_resistor":  # I = V / R: a relative error of R is a -1 relative gain
                out[q] = [-c / std.value if std.dimension == "resistance" else
                          -c * std.factor("1") for c in gain]
            else:
                dt = float(lab.environment.get("temperature_tolerance_degC", 1.0))
                out[q] = [-c * dt * std.factor("1/degC") for c in gain]
        elif q in ("head_angle", "autocollimator"):
            key = data_model.vectors.get(q, "angles")
            if key not in vectors:
                vectors[key] = per_position(data_model, rows, std.u_in("rad") or 1e-6, key)
            each = vectors[key] * std.factor("rad")
            out[q] = [float(c) for c in (each**2).sum(axis=1) ** 0.5]  # independent, one u
            components[q] = [tuple(float(c) for c in line) for line in each]
        elif q == "head_axis_tilt":
            out[q] = _tilt(rows, reduction, model, data_model, std)
    return rows, out, components


def _tilt(rows, reduction, model, data_model, std) -> list[float]:
    """Bias per tilt: the misalignment toward the rotation axis (first order)."""
    out = []
    for row in rows:
        m = model or reduction.models[row.sensor]
        toward = getattr(m, "Ko" if data_model.rotation_axis == "OA" else "Kp", 0.0) if m else 0.0
        out.append(toward * 1e6 * std.factor("rad") if row.kind == "bias" else 0.0)
    return out


def itemise(reduction, lab, *, data_model: DataModel | None = None, inputs=(), model=None,
            notes=()) -> list:
    """One :class:`~accelcal.budget.gum.Budget` per reported coefficient (see module doc).

    Parameters
    ----------
    reduction : accelcal.results.Reduction
    lab : accelcal.budget.lab.Lab
    data_model : DataModel, optional
        The method's data, perturbable (None: the inputs entering through
        the data are left out, and the notes say so).
    inputs : sequence of str
        The method's input quantities (:data:`Method.budget_inputs`).
    model : accelcal.model.ErrorModel, optional
        The sensor's model for its temperature coefficients (default: the
        reduction's models).
    notes : sequence of str
        Added to every budget's notes.
    """
    notes = list(notes)
    missing = [q for q in inputs if q not in lab.standards]
    if missing and lab.sha256:  # a lab file (not the empty lab of no file)
        notes.append(f"inputs of the method's model not declared in the lab file (not in the "
                     f"budget): {', '.join(missing)}")
    if not inputs:
        notes.append(NO_MODEL)
    late = [s for s in lab.expired() if s.quantity in inputs]
    if late:
        notes.append("standard(s) past their due date used: " + ", ".join(
            f"{s.quantity} (certificate {s.certificate or '?'}, due {s.due})" for s in late))
    rows, sens, components = sensitivities(reduction, lab, data_model, inputs, model=model,
                                           notes=notes)
    dof_a = reduction.dof if reduction.dof > 0 else math.inf
    out = []
    for i, row in enumerate(rows):
        own = list(notes)
        factor = row.std / row.native_std if row.native_std else 1.0
        terms = []
        type_b = 0.0
        for c in (() if row.part else reduction.contributions(row.label, row.sensor)):
            part = c.contribution * factor
            type_b += part * part
            prior = _prior_of(reduction, c.input)
            terms.append((Input(f"prior {c.input}", 0.0 if prior is None else prior.value, c.u,
                                "" if prior is None else prior.unit,
                                "normal" if prior is None else prior.distribution, c.dof,
                                "prior", c.source), c.sensitivity * factor))
        var_a = max(row.std**2 - type_b, 0.0)
        terms.insert(0, (Input("Type A", row.estimate, math.sqrt(var_a), row.unit, "student-t"
                               if math.isfinite(dof_a) else "normal", dof_a, "type A",
                               reduction.method), 1.0))
        for q, cs in sens.items():
            if math.isfinite(cs[i]):
                parts = components[q][i] if q in components else ()
                std = lab.standards[q]
                if data_model is not None and q in data_model.per_row:  # as it applies here
                    std = data_model.per_row[q](row, std, lab)[0]
                terms.append((_lab_input(std, parts), cs[i]))
            else:
                own.append(f"{q}: the reduction run again on the perturbed data did not give "
                           f"{row.title}; not in this budget")
        serial = reduction.sensor_names[row.sensor]
        if row.relative and not row.part:
            own.insert(0, f"{row.label} = {row.base:.10g} {row.native_unit}; no nominal scale "
                          "factor given: its budget in ppm of the estimate")
        elif row.part == "magnitude":
            own.insert(0, f"{row.title} = {row.base:.10g} {row.native_unit}; its budget in % "
                          "of the estimate")
        out.append(combine(row.title, row.estimate, row.unit, terms,
                           correlation=lab.correlations, sensor=row.sensor, serial=serial,
                           notes=own))
    return out


def bowed(outputs, linearity: float):
    """Outputs with an integral nonlinearity of ``linearity`` (relative) at full scale.

    ``v + linearity |v| v / max|v|``: a second-order bow, zero at zero and
    ``linearity`` of the reading at the largest reading.
    """
    import numpy as np

    v = np.asarray(outputs, dtype=float)
    if not linearity:
        return v
    full = np.abs(v).max()
    return v + linearity * np.abs(v) * v / full if full else v
