"""The model fit's measurement model for budgets: the comparison's inputs through its points.

A model-fit reduction (:func:`accelcal.methods.response.model.fit_model`:
``S0``, ``fn``, ``zeta``, ``f_3dB`` and the extra pole or delay where
fitted) is a function of the complex points it was fitted to (its
observations ``frequency_hz``, ``response`` and ``covariance``), and the
comparison's inputs (:mod:`accelcal.methods.response.budget`) enter it
through those points. Each input moves every point ``p_i`` by a factor
``exp(x g_i)``, ``g_i = c_mag,i / 100 + i (pi / 180) c_phase,i`` from the
comparison's own coefficients at that point (% and deg per unit of the
input), and its sensitivity coefficient on each fitted quantity is found by
fitting the model again to the moved points, by central differences with
the step ``u(x)`` (Kragten [Kragten1994]_), the points' weights kept and
the fit started from its own solution:

- ``reference_sensitivity``, ``daq_gain_mismatch``, ``sensor_temperature``
  (``alpha``) and ``sensitivity_tc`` (``dT``): a common relative factor
  ``1 + d`` on every point; the model is linear in ``S0``, so ``S0`` moves
  by ``S0 d`` and ``fn``, ``zeta``, ``f_3dB`` not at all (the re-fits
  find ``|c| / fn`` below 1e-6 per unit of ``d``,
  ``tests/methods/response/test_response_fit_budget.py``);
- ``reference_phase``: a common phase offset on every point (it moves
  ``fn`` and ``zeta``, and the delay where fitted);
- ``daq_delay_mismatch``: ``exp(-i 2 pi f tau)`` on the points (``fn``,
  ``zeta``; the delay term where fitted takes it nearly whole);
- ``relative_motion``, ``transverse_motion`` (times ``s_T``) and
  ``transverse_sensitivity`` (times ``tau``): a complex factor, each
  component with the lab's ``u`` and independent, so each is re-fitted on
  its own (the real part a common gain, the imaginary part a common phase)
  and the row's coefficient is their root-sum-square, signed as the larger;
- ``frequency``: the comparison's coefficient at each point (the slopes of
  the DUT's and the reference's responses and, with the data, the sine
  fits' own response to the frequency error);
- ``daq_gain``, ``daq_linearity`` and ``distortion``: with the data at
  hand, the comparison reduced again from the perturbed data and the model
  fitted again (a common gain on both channels cancels); without them
  ``distortion`` is 0 and the DAQ's gain and linearity are left out.

Without the points (a calibration record whose input files were not found
holds the fit's numbers alone) the common gains enter in closed form,
``S0 d`` on ``S0`` and nothing on the rest, and the other inputs are named
as left out.

Correlation between the points: each input is one error common to every
point (one reference calibration, one DAQ, one mounting, one sensor
temperature), fully correlated across the points. The reference's
certificate table gives a ``U`` per frequency; the error common to the
points is taken as the table's ``U / 2`` interpolated at the reference
frequency (the record's ``reference_frequency``, where the magnitude and
phase are tied to the reference's calibration and where the certificate
states the deviations from), applied as one relative error (one phase
offset) to every point: the magnitude's common part is what a fit's
``S0`` inherits, and a table that states a larger ``U`` elsewhere states
the frequency-dependent part of it, which the fit's weights spread over
the band.

The points' source: with the data at hand, their excitation says the route
(a laser or gravity record has none of these inputs); without them the
points are taken as a comparison's (the route of ``accelcal response
fit``'s records).

References
----------
.. [Kragten1994] Kragten J., Calculating standard deviations and confidence
   intervals with a universally applicable spreadsheet technique, Analyst
   119 (1994) 2161-2165.
.. [ISO16063-21] ISO 16063-21:2003, annex A (the reference's calibration
   as one input common to every frequency).
.. [GUM] JCGM 100:2008, 5.2 (correlated input quantities).
"""

import dataclasses
import math

COMPONENTS = ("relative_motion", "transverse_motion", "transverse_sensitivity")
"""Complex inputs: each component independent with the lab's ``u`` (re-fitted one at a time)."""

TABLE_INPUTS = ("reference_sensitivity", "reference_phase")
"""Inputs whose standard the reference's table gives per frequency: the reference
frequency's applies to every point."""


def points_of(fit, method: str, points=None):
    """The complex points a model-fit reduction was fitted to, as a reduction of ``method``.

    The names are ``S(f Hz)`` (``S(f Hz) #k`` for a repeated frequency), the
    covariance the points' own, the reference frequency the fit's.
    ``points``: ``(frequency_hz, response, covariance)`` instead of the fit's
    observations.
    """
    import numpy as np

    from accelcal.results import Assumption, Estimate, Reduction

    obs = fit.observations
    f, values, covariance = points or (obs["frequency_hz"], obs["response"],
                                       obs["covariance"])
    f = np.asarray(f, dtype=float)
    names, seen = [], {}
    for fi in f.tolist():
        seen[fi] = seen.get(fi, 0) + 1
        names.append(f"S({fi:g} Hz)" + (f" #{seen[fi]}" if seen[fi] > 1 else ""))
    unit = fit.estimate.units.get("S0", "")
    est = Estimate(tuple(names), np.asarray(values, dtype=complex),
                   np.asarray(covariance, dtype=float), dict.fromkeys(names, unit), method,
                   dof=0)
    assumed = tuple(a for a in fit.assumptions if a.name == "reference_frequency") or (
        Assumption("reference_frequency", float(f[0]), "Hz", ""),)
    return Reduction(family=fit.family, method=method, sensors=(est,), sensor_names=("dut",),
                     dof=0, assumptions=assumed, observations={"frequency_hz": f})


class Refit:
    """The fit of a model-fit reduction made again on its points moved by ``exp(x g)``."""

    def __init__(self, fit, points) -> None:
        import numpy as np

        from accelcal.methods.response.model import BANDWIDTH

        self.fit, self.points = fit, points
        self.model = fit.assumed("model", "second-order")
        est = fit.estimate
        self.start = [float(v) for n, v in zip(est.names, est.values, strict=True)
                      if n != BANDWIDTH]
        self.values = np.asarray(points.estimate.values, dtype=complex)

    def again(self, reduction):
        """``fit_model`` of ``reduction``'s points, from the fit's solution."""
        from accelcal.methods.response.model import fit_model

        return fit_model(reduction, self.model, start=self.start)

    def moved(self, g, x: float) -> dict:
        """The fitted values (by name) of the points times ``exp(x g)``."""
        import numpy as np

        est = self.points.estimate
        moved = dataclasses.replace(est, values=self.values * np.exp(x * np.asarray(g)))
        red = dataclasses.replace(self.points, sensors=(moved,))
        out = self.again(red).estimate
        return dict(zip(out.names, np.asarray(out.values, dtype=float).tolist(), strict=True))

    def coefficients(self, g, h: float) -> dict:
        """``d y / d x`` of every fitted quantity by central differences with step ``h``."""
        import numpy as np

        from accelcal.errors import AccelcalError

        if not np.any(np.asarray(g)):
            return {}  # the points do not move: zero
        try:
            plus, minus = self.moved(g, h), self.moved(g, -h)
        except (AccelcalError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            return dict.fromkeys(self.fit.estimate.names, math.nan)
        return {n: (plus.get(n, math.nan) - minus.get(n, math.nan)) / (2.0 * h)
                for n in self.fit.estimate.names}


def _reference_point(points) -> int:
    import numpy as np

    f = np.asarray(points.observations["frequency_hz"], dtype=float)
    f_ref = float(points.assumed("reference_frequency", f[0]))
    return int(np.argmin(np.abs(np.log(f / f_ref))))


def _per_point(comparison, rows, q, std, lab):
    """Per point: the standard as it applies and ``(c_mag %, c_phase deg)`` per its unit.

    A string where the comparison says why ``q`` is not an input.
    """
    if q in comparison.per_row:
        each = [comparison.per_row[q](r, std, lab) for r in rows]
        why = next((e for e in each if isinstance(e, str)), None)
        if why is not None:
            return why
    else:
        each = [(std, comparison.analytic[q](r, std)) for r in rows]
    out: dict = {}
    for r, (s, c) in zip(rows, each, strict=True):
        standard, mag, phase = out.get(r.label, (s, 0.0, 0.0))
        if r.part == "magnitude":
            out[r.label] = (s, c, phase)
        else:
            out[r.label] = (standard, mag, c)
    return list(out.values())


def per_row_inputs(refit: Refit, comparison) -> dict:
    """``quantity -> per_row(row, std, lab)`` of a fit's rows, by re-fitting moved points.

    The comparison's inputs stated per point (:attr:`DataModel.per_row` and
    ``analytic`` of the points' :func:`accelcal.methods.response.budget.data_model`).
    """
    import numpy as np

    from accelcal.budget.engine import _rows

    fit, points = refit.fit, refit.points
    rows = _rows(points)
    i_ref = _reference_point(points)
    cache: dict = {}

    def coefficients(q, std, lab):
        found = _per_point(comparison, rows, q, std, lab)
        if isinstance(found, str):
            return found
        if q in TABLE_INPUTS:  # one error of the reference, its value at the reference frequency
            found = [found[i_ref]] * len(found)
        here = found[i_ref][0]
        mag = np.array([m for _, m, _ in found]) / 100.0
        phase = np.radians([p for _, _, p in found])
        h = here.u or 1.0
        if q not in COMPONENTS:
            return here, refit.coefficients(mag + 1j * phase, h)
        re, im = refit.coefficients(mag, h), refit.coefficients(1j * phase, h)
        out = {}
        for n in fit.estimate.names:
            a, b = re.get(n, 0.0), im.get(n, 0.0)
            out[n] = math.copysign(math.hypot(a, b), a if abs(a) >= abs(b) else b)
        return here, out

    def make(q):
        def per_row(row, std, lab):
            if q not in cache:
                cache[q] = coefficients(q, std, lab)
            found = cache[q]
            if isinstance(found, str):
                return found
            here, cs = found
            return here, cs.get(row.label, 0.0)

        return per_row

    names = set(comparison.per_row) | set(comparison.analytic)
    return {q: make(q) for q in sorted(names)}


ROUTES = {"stepped": "response/comparison", "random": "response/broadband",
          "swept": "response/broadband", "laser": "response/laser",
          "gravity": "response/gravity"}
"""Method id of the points by the excitation of their records."""


GAINS = ("reference_sensitivity", "daq_gain_mismatch", "sensor_temperature",
         "sensitivity_tc")
"""Inputs that are a common relative factor on every point: ``S0 d`` without the points."""


def _without_points(fit, comparison):
    """A fit whose points are not at hand: the common gains alone, ``c = S0 d`` on ``S0``.

    The comparison's closed forms at one point at the reference frequency
    give ``d`` per unit of each; the other inputs need the points and are
    named as left out.
    """
    from accelcal.budget.engine import DataModel, _rows
    from accelcal.methods.response.stepped import REFERENCE_FREQUENCY

    f_ref = float(fit.assumed("reference_frequency", REFERENCE_FREQUENCY))
    s0 = complex(fit.estimate.values[fit.estimate.names.index("S0")])
    one = points_of(fit, ROUTES["stepped"], ([f_ref], [s0], [[0.0, 0.0], [0.0, 0.0]]))
    model, rows = comparison(one, None), _rows(one)

    def make(q):
        def per_row(row, std, lab):
            if q not in GAINS:
                return ("the points the fit was made from were not found (the common gains "
                        "alone enter, in closed form)")
            found = _per_point(model, rows, q, std, lab)
            if isinstance(found, str):
                return found
            here, mag, _ = found[0]
            return here, (row.base * mag / 100.0 if row.label == "S0" else 0.0)

        return per_row

    return DataModel(None, 0, "V", per_row={q: make(q) for q in sorted(
        set(model.per_row) | set(model.analytic))})


def data_model(fit, records, comparison):
    """A :class:`~accelcal.budget.engine.DataModel` of a model-fit reduction (module docs).

    ``comparison(points, records)`` is the points' own measurement model
    (:func:`accelcal.methods.response.budget.data_model`).
    """
    from os import PathLike

    from accelcal.budget.engine import DataModel

    if "response" not in fit.observations:  # a record's numbers, without the points
        return _without_points(fit, comparison)
    items = [] if records is None else (
        list(records) if isinstance(records, list | tuple) else [records])
    method = ROUTES["stepped"]
    if items:
        from accelcal.io.formats.response import read
        from accelcal.methods.response import excitation_of

        method = ROUTES.get(excitation_of(items[0]), method)
        if method not in (ROUTES["stepped"], ROUTES["random"]):  # no comparison's inputs
            return comparison(points_of(fit, method), None)
        items = [read(r) if isinstance(r, str | PathLike) else r for r in items]
    points = points_of(fit, method)
    model = comparison(points, items or None)
    refit = Refit(fit, points)
    rerun = None
    if model.reduce is not None:
        def rerun(**shift):
            return refit.again(model.reduce(**shift))

    return DataModel(rerun, 0, model.output_unit, parameters=model.parameters,
                     per_row=per_row_inputs(refit, model))
