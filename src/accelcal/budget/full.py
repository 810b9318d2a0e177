"""The full measurement model of a budget: every input drawn, the method's reduction run again.

JCGM 101 propagates the input distributions through the measurement model
itself, not its linearisation. :func:`model_of` builds, from the budgets of
one reduction, a Monte Carlo study (:class:`Study`, a ``simulate(rng, n)``
of :func:`accelcal.montecarlo.run`) whose every trial

- draws each lab input from its distribution with its standard uncertainty
  (:func:`accelcal.budget.mc.sample`; correlated scalar inputs through a
  Gaussian copula), each position's angle error of a vector input on its
  own;
- runs the method's reduction again on the data perturbed by all the
  inputs that enter through the data at once -- the route of the Kragten
  differences (:class:`~accelcal.budget.engine.DataModel`): the DAQ's gain
  (with the load resistor's ``V = I R``: a resistor ``R + dR`` read as
  ``R`` is the gain ``R / (R + dR) - 1``; gains compose as products), offset
  and linearity, each position's angle, the test's parameters -- and takes
  every reported coefficient's change from the unperturbed re-run;
- applies the inputs the engine states in closed form, in their exact
  form: local gravity ``y (g / g0)^p`` (``p`` the coefficient's power of
  ``g``, :data:`~accelcal.budget.engine.ORDER_EXPONENT`; a scale factor in
  ppm through its ratio), the tilt ``beta`` of the rotation axis (the
  in-plane ``1 g`` is ``g cos beta``: ``y cos(beta)^p``, and gravity
  ``g sin beta`` along the axis through the misalignment toward it), the
  sensor's temperature through its temperature polynomial;
- adds the Type A part (a scaled and shifted t, JCGM 101 6.4.9.7), the
  priors of unestimated terms and a method's closed-form inputs
  (:attr:`DataModel.analytic` and ``per_row``) with the budget's
  sensitivities, per the lab's ``u`` (a row whose standard is its own, a
  reference's table at its frequency, moves by its contribution per
  standard draw): the reductions are linear in the data they stand for.

A trial whose reduction fails gives NaN (counted, left out of the
intervals). Each trial also gives the budgets' linearised model
``y0 + sum_i c_i dx_i`` on the same draws (:attr:`Study.part`): the
control variate of :func:`accelcal.budget.mc.propagate`.

References
----------
.. [JCGM101] JCGM 101:2008, secs. 5.9, 6.4, 7.
.. [Kragten1994] Kragten J., Analyst 119 (1994) 2161-2165.
"""

import math
from dataclasses import dataclass, field

from accelcal.budget.engine import CORRECTIONS, ORDER_EXPONENT

DATA_KEYS = ("gain", "offset", "linearity")
"""Keywords of :attr:`DataModel.reduce` that act on the outputs."""


@dataclass(frozen=True)
class Entry:
    """How one lab input enters the full model.

    ``route``: ``shift`` (a keyword of the reduction, ``per`` of it per lab
    unit), ``resistor`` (a relative gain ``1 / (1 + per x) - 1``), ``vector``
    (one error per position: ``keyword`` in rad, ``per`` rad per lab unit),
    ``gravity`` (``value`` in m/s², ``per`` m/s² per lab unit), ``tilt``
    (``per`` rad per lab unit), ``temperature`` (degC per lab unit) or
    ``linear`` (the budget's sensitivity).
    """

    quantity: str
    route: str
    distribution: str
    u: float
    dof: float
    keyword: str = ""
    per: float = 1.0
    value: float = 0.0


@dataclass(frozen=True)
class Study:
    """One reduction's budgets as a Monte Carlo study: ``study(rng, n) -> (n, rows)``.

    Picklable (with cloudpickle, as Dask sends it) when the method's
    ``reduce`` is.
    """

    reduce: object
    rows: tuple
    estimates: tuple
    base: tuple
    n_positions: int
    entries: tuple
    linear: tuple = ()
    """``(quantity, distribution, u, dof, sensitivities per row)`` added linearly."""
    type_a: tuple = ()
    """``(u, dof)`` per row."""
    correlation: dict = field(default_factory=dict)
    """``{"names": coupled inputs, "matrix": their correlation}`` (empty: none)."""
    sensitivity: dict = field(default_factory=dict)
    """``quantity -> sensitivities per row`` (the budgets')."""
    temperature: tuple = ()
    """``(reference, {k: c_k}, scale, lab temperature) or None`` per row."""
    components: dict = field(default_factory=dict)
    """``quantity -> per-position sensitivities per row`` of the vector inputs (the budgets')."""
    part: str = "both"
    """``"both"``: each trial's full-model values, then its linearised ones (``(n, 2 rows)``,
    the same draws); ``"linear"``: the linearised ones only (vectorised)."""

    @property
    def reruns(self) -> bool:
        """Whether a trial runs the reduction again (else it is vectorised)."""
        return self.reduce is not None and any(
            e.route in ("shift", "resistor", "vector") for e in self.entries)

    def __call__(self, rng, n: int):
        """``n`` trials drawn from ``rng``: shape ``(n, 2 rows)`` or ``(n, rows)`` (``part``)."""
        import numpy as np

        draws = self._draws(rng, n)
        linear = self._linearised(draws, n)
        if self.part == "linear":
            return linear
        return np.hstack([self._full(draws, n), linear])

    def _linearised(self, draws: dict, n: int):
        """The budgets' model ``y0 + sum_i c_i dx_i`` on the same draws (the control variate)."""
        import numpy as np

        y = np.tile(np.asarray(self.estimates, dtype=float), (n, 1))
        for e in self.entries:
            if e.route == "vector":
                y += draws[e.quantity] @ np.asarray(self.components[e.quantity]).T
            else:
                y += draws[e.quantity][:, None] * np.asarray(self.sensitivity[e.quantity])[None]
        return self._added(y, draws)

    def _added(self, y, draws: dict):
        """``y`` with the inputs added linearly in both models and the Type A parts."""
        import numpy as np

        for quantity, _, _, _, sens in self.linear:
            y += draws[quantity][:, None] * np.asarray(sens)[None, :]
        for j, (u, _) in enumerate(self.type_a):
            if u > 0:
                y[:, j] += draws[("Type A", j)]
        return y

    def _full(self, draws: dict, n: int):
        """Every row's value in the full model (module doc)."""
        import numpy as np

        y = np.tile(np.asarray(self.estimates, dtype=float), (n, 1))
        if self.reruns:
            y += self._rerun(draws, n)
        for e in self.entries:
            x = draws[e.quantity]
            if e.route == "gravity":
                y = self._scaled(y, ((e.value + x * e.per) / e.value)[:, None])
            elif e.route == "tilt":
                beta = x * e.per
                y = self._scaled(y, np.cos(beta)[:, None])
                y += np.sin(beta)[:, None] / e.per * np.asarray(
                    self.sensitivity[e.quantity])[None, :]
            elif e.route == "temperature":
                y += self._temperature(x)
        return self._added(y, draws)

    def _draws(self, rng, n: int) -> dict:
        """Every input's draws in the study's order (the same for a given generator)."""
        import numpy as np

        from accelcal.budget.mc import sample

        coupled = self.correlation.get("names", ())
        normals = {}
        if coupled:
            z = rng.multivariate_normal(np.zeros(len(coupled)), self.correlation["matrix"],
                                        size=n, method="eigh")
            normals = {q: z[:, i] for i, q in enumerate(coupled)}
        out = {}
        for e in self.entries:
            if e.route == "vector":
                out[e.quantity] = sample(e.distribution, e.u, e.dof, n * self.n_positions,
                                         rng).reshape(n, self.n_positions)
            else:
                out[e.quantity] = sample(e.distribution, e.u, e.dof, n, rng,
                                         normal=normals.get(e.quantity))
        for quantity, distribution, u, dof, _ in self.linear:
            out[quantity] = sample(distribution, u, dof, n, rng, normal=normals.get(quantity))
        for j, (u, dof) in enumerate(self.type_a):
            if u > 0:
                out[("Type A", j)] = sample("student-t" if math.isfinite(dof) else "normal", u,
                                            dof, n, rng)
        return out

    def _rerun(self, draws: dict, n: int):
        """Each trial's change of every row in the reduction of the perturbed data."""
        import numpy as np

        from accelcal.budget.engine import _run

        base = np.asarray(self.base, dtype=float)
        out = np.empty((n, len(self.rows)))
        for i in range(n):
            shift, gain = {}, 1.0
            for e in self.entries:
                x = draws[e.quantity][i]
                if e.route == "resistor":
                    gain *= 1.0 / (1.0 + e.per * x)
                elif e.route == "vector":
                    shift[e.keyword] = shift.get(e.keyword, 0.0) + x * e.per
                elif e.route == "shift" and e.keyword == "gain":
                    gain *= 1.0 + x * e.per
                elif e.route == "shift":
                    shift[e.keyword] = shift.get(e.keyword, 0.0) + x * e.per
            if gain != 1.0:
                shift["gain"] = gain - 1.0
            out[i] = np.asarray(_run(_Model(self.reduce), self.rows, **shift)) - base
        out[:, ~np.isfinite(base)] = 0.0  # rows the unperturbed re-run does not give
        return out

    def _scaled(self, y, factor):
        """Rows multiplied by ``factor`` to the power of their order in ``g`` (module doc)."""
        import numpy as np

        powers = np.asarray([ORDER_EXPONENT.get(r.kind or "", 0) for r in self.rows], float)
        scaled = factor**powers[None, :]
        scale = np.asarray([r.kind == "scale" for r in self.rows])[None, :]
        # a scale factor in ppm of its nominal: the ratio (1 + y 1e-6) is scaled
        return np.where(scale, ((1.0 + y * 1e-6) * scaled - 1.0) * 1e6, y * scaled)

    def _temperature(self, x):
        import numpy as np

        out = np.zeros((len(x), len(self.rows)))
        for j, poly in enumerate(self.temperature):
            if poly is None:
                continue
            reference, c, scale, at = poly
            dt = at - reference
            out[:, j] = scale * sum(c[k] * ((dt + x) ** k - dt**k) for k in c)
        return out


@dataclass(frozen=True)
class _Model:
    """The :func:`~accelcal.budget.engine._run` view of a reduce callable."""

    reduce: object


def model_of(budgets, reduction, lab, data_model, *, model=None) -> tuple[Study, list[str]]:
    """The full-model study of a reduction's budgets (as :func:`itemise` made them, in order).

    Parameters
    ----------
    budgets : list of Budget
        :func:`~accelcal.budget.engine.itemise`'s, one per reported row.
    reduction, lab, data_model, model :
        As given to :func:`~accelcal.budget.engine.itemise`.

    Returns
    -------
    study : Study
    notes : list of str
        Inputs entered linearly, and why.
    """
    import numpy as np

    from accelcal.budget.engine import _rows, _run, temperature_polynomial

    rows = tuple(_rows(reduction))
    if len(rows) != len(budgets):
        raise ValueError("the budgets are not the reduction's rows")
    in_budget = []
    for b in budgets:
        for r in b.rows:
            if r.source == "lab" and r.quantity not in in_budget:
                in_budget.append(r.quantity)
    # per the lab's u: a row's standard may be its own (a table's)
    sens = {q: [_per_lab(b, q, lab.standards[q].u) for b in budgets] for q in in_budget}
    notes, entries, linear = [], [], []
    for q in in_budget:
        std = lab.standards[q]
        e = _entry(q, std, data_model, lab)
        if e.route == "linear":
            notes.append(f"{q}: in closed form to first order in the method's model; drawn "
                         "and entered linearly")
            linear.append((q, std.distribution, std.u, std.dof, tuple(sens[q])))
            continue
        entries.append(e)
    temperature = ()
    if any(e.route == "temperature" for e in entries):
        at = lab.standards["sensor_temperature"].value_in("degC")
        polys = [temperature_polynomial(r, model or reduction.models[r.sensor]) for r in rows]
        temperature = tuple(None if p is None else (*p, at) for p in polys)
    priors = []
    for b in budgets:
        for r in b.rows:
            if r.source == "prior" and r.quantity not in [p[0] for p in priors]:
                priors.append((r.quantity, r.distribution, r.u, r.dof,
                               tuple(_row_sensitivity(x, r.quantity) for x in budgets)))
    type_a = tuple(next(((r.u, r.dof) for r in b.rows if r.source == "type A"), (0.0, math.inf))
                   for b in budgets)
    names = [e.quantity for e in entries if e.route != "vector"] + [p[0] for p in linear]
    correlation = {}
    pairs = {}
    for (a, b), r in lab.correlations.items():
        if a in names and b in names:
            pairs[(a, b)] = pairs[(b, a)] = r
        elif a in in_budget and b in in_budget:
            notes.append(f"the correlation of {a} and {b} (a per-position input) is not drawn")
    if pairs:
        coupled = tuple(sorted({q for p in pairs for q in p}, key=names.index))
        matrix = np.eye(len(coupled))
        for i, a in enumerate(coupled):
            for j, b in enumerate(coupled):
                if i != j:
                    matrix[i, j] = pairs.get((a, b), 0.0)
        correlation.update(names=coupled, matrix=matrix)
    reduce = data_model.reduce if data_model is not None else None
    base = tuple(_run(_Model(reduce), list(rows))) if reduce is not None else (0.0,) * len(rows)
    study = Study(reduce, rows, tuple(b.estimate for b in budgets), base,
                  _positions(data_model), tuple(entries),
                  tuple(linear) + tuple(priors), type_a, correlation,
                  {q: tuple(s) for q, s in sens.items()}, temperature,
                  _components(budgets, entries, _positions(data_model)))
    return study, notes


def _positions(data_model) -> int:
    """Positions of a data model (0 without one)."""
    return data_model.n_positions if data_model is not None else 0


def _components(budgets, entries, n_positions: int) -> dict:
    """Per-position sensitivities per row of each vector entry (zeros where a row has none)."""
    out = {}
    for e in entries:
        if e.route == "vector":
            out[e.quantity] = tuple(
                next((r.components for r in b.rows if r.quantity == e.quantity and r.components),
                     (0.0,) * n_positions) for b in budgets)
    return out


def _row_sensitivity(budget, quantity: str) -> float:
    return next((r.sensitivity for r in budget.rows if r.quantity == quantity), 0.0)


def _per_lab(budget, quantity: str, u: float) -> float:
    """The row's sensitivity per the lab's ``u``.

    ``c u_row / u`` where the row's standard is its own (a reference's table at
    the row's frequency), so that a draw of the lab's input moves the row by
    its contribution.
    """
    row = next((r for r in budget.rows if r.quantity == quantity), None)
    if row is None:
        return 0.0
    return row.sensitivity if row.u == u or not u > 0 else row.sensitivity * row.u / u


def _entry(q, std, data_model, lab) -> Entry:
    """How the lab's input ``q`` enters (the branches of :func:`engine.sensitivities`)."""
    def entry(route, keyword="", per=1.0, value=0.0):
        return Entry(q, route, std.distribution, std.u, std.dof, keyword, per, value)

    rerun = data_model is not None and data_model.reduce is not None
    if data_model is not None and (q in data_model.analytic or q in data_model.per_row):
        return entry("linear")
    if rerun and q in data_model.parameters:
        keyword, unit = data_model.parameters[q][std.dimension]
        return entry("shift", keyword, 1.0 / std.value if unit == "/value" and std.value
                     else std.factor(unit))
    if q == "local_gravity":
        return entry("gravity", per=std.factor("m/s^2"), value=std.value_in("m/s^2"))
    if q == "sensor_temperature":
        return entry("temperature")
    if not rerun or q not in (*CORRECTIONS, "load_resistor_tc"):
        return entry("linear")
    if q in ("daq_gain", "daq_linearity"):
        return entry("shift", "gain" if q == "daq_gain" else "linearity", std.factor("1"))
    if q == "daq_offset":
        return entry("shift", "offset", std.u_in(data_model.output_unit) / std.u if std.u
                     else 1.0)
    if q == "load_resistor":  # I = V / R: R + dR read as R
        return entry("resistor", per=1.0 / std.value if std.dimension == "resistance"
                     else std.factor("1"))
    if q == "load_resistor_tc":
        dt = float(lab.environment.get("temperature_tolerance_degC", 1.0))
        return entry("resistor", per=dt * std.factor("1/degC"))
    if q in ("head_angle", "autocollimator"):
        return entry("vector", data_model.vectors.get(q, "angles"), std.factor("rad"))
    if q == "head_axis_tilt":
        return entry("tilt", per=std.factor("rad"))
    return entry("linear")
