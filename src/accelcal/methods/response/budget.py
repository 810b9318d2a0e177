"""The frequency response's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

By comparison (ISO 16063-21 [ISO16063-21]_) the reduction gives the DUT's
complex sensitivity at a step of frequency ``f`` as::

    S = S_ref(f) (u_dut / u_ref) / D(f),    D(f) = g exp(-i 2 pi f tau_daq),

``u_dut / u_ref`` the ratio of the channels' fitted phasors (the voltage
ratio: its Type A part, the channels' noise and the fits' scatter, is the
budget's ``Type A`` row), ``S_ref`` the reference's certificate
interpolated at ``f`` and ``D`` the DAQ's channel mismatch the record
states. The influence quantities move the data, and so the result, by::

    (1 + gamma) exp(-i 2 pi f delta) (1 + rho + s_T tau) (1 + alpha dT),

``gamma`` and ``delta`` the DAQ's gain and delay mismatch beyond ``D``,
``rho`` the DUT's motion relative to the reference's, ``tau`` the
transverse motion along the DUT's most sensitive transverse axis and
``s_T`` its transverse sensitivity, ``alpha`` the DUT's sensitivity
temperature coefficient and ``dT`` its temperature's departure from the
lab's stated one. Each step's magnitude (in % of its estimate) and phase
(deg) get a budget; a complex factor ``1 + x`` moves ``ln|S|`` by ``Re x``
and the phase by ``Im x`` rad. In closed form:

- ``reference_sensitivity``: 1 % per % on the magnitude, with the
  certificate table's ``U`` (k = 2) interpolated linearly at ``f`` when the
  record's table states it (the lab's entry names the standard, its dof and
  due date), else the lab's ``u``; ``reference_phase`` likewise, 1 deg per
  deg on the phase;
- ``daq_gain_mismatch``: 1 % per % on the magnitude; ``daq_delay_mismatch``:
  ``-360 f`` deg per s on the phase (``-2 pi f`` rad per s);
- ``relative_motion`` and ``transverse_motion`` (each component of the
  lab's ``u``): 1 and ``s_T`` on the magnitude (% per %) and
  ``180 / pi`` and ``180 s_T / pi`` deg per unit on the phase;
  ``transverse_sensitivity``: ``tau``, the lab's transverse motion (zero:
  the product enters at second order);
- ``sensor_temperature``: ``alpha`` (%/degC) on the magnitude;
  ``sensitivity_tc``: ``dT`` (the lab's ``sensor_temperature`` less its
  ``[environment] temperature_degC``, default 23 degC);
- ``frequency``: a generator error ``e`` makes the data those of ``f + e``
  reduced as ``f``: ``d ln S / d e = L'_dut - L'_ref - F``, the
  slopes of ``ln S`` of the DUT (from the reduction's points) and of the
  reference (its table), and ``F`` the sine fits' own response to a
  mismatch of the data's and the fit's frequency, found by re-running the
  reduction with the stated frequency moved (the reduction re-run moves
  ``L'_ref + F``, so ``c = L'_dut - c_rerun``); without the data, or for
  broadband excitation (no sine fits), the slopes alone;
- ``distortion``: 0 (the fits hold the 2nd and 3rd harmonics), and with the
  data at hand found by re-running the reduction with both harmonics added
  to both channels; not an input of broadband excitation;
- ``daq_gain``, ``daq_linearity``: re-run on both channels (a common gain
  cancels in the ratio).

Signs: an influence quantity's coefficient is its effect on the result
(the data's view, as the re-runs find it: a DUT 0.1 degC warmer reads
``alpha 0.1`` more); the reference's, that of its certificate's value in
the model (``S`` is proportional to ``S_ref``). With the influence
quantities' estimates zero and their distributions symmetric, the signs
change no budget.

Laser and gravity reductions are not comparisons: these inputs are named as
not entering them. A model-fit reduction takes them through the points it
was fitted to, re-fitted (:mod:`accelcal.methods.response.budget_fit`).
Each closed form is checked against the
reduction of re-simulated data (central differences) in
``tests/methods/response/test_response_budget.py``.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Vibration calibration by comparison to a
   reference transducer, annex A (uncertainty budget).
.. [GUMS2] JCGM 102:2011 (GUM Supplement 2), sec. 6 (complex quantities).
"""

import dataclasses
import math

TABLE_K = 2.0
"""Coverage factor of a reference table's ``U`` (ISO 16063-21 certificates: k = 2)."""

STEP = 1e-6
"""Relative step of the stated frequency in the re-run that finds the fits' response."""

_DEG = 180.0 / math.pi


def _part(row, magnitude: float, phase_rad: float) -> float:
    """A relative (magnitude) and radian (phase) effect as the row's coefficient (% or deg)."""
    return 100.0 * magnitude if row.part == "magnitude" else _DEG * phase_rad


def _declared(lab, quantity: str, unit: str, default: float | None = 0.0):
    std = lab.standards.get(quantity)
    return default if std is None else std.value_in(unit)


def _frequencies(reduction) -> list[float]:
    """Each point's frequency in Hz: the reduction's, or read from its name ``S(f Hz...)``.

    A reduction rebuilt from a calibration record whose data were not found
    has its rows but not its observations.
    """
    from accelcal.methods.response.stepped import point_of

    if "frequency_hz" in reduction.observations:
        return [float(f) for f in reduction.observations["frequency_hz"]]
    found = [point_of(n) for n in reduction.estimate.names]
    if not all(found):
        from accelcal.errors import AccelcalError

        raise AccelcalError("a frequency-response record without its observations has a row "
                            "not named S(f Hz): its frequencies are unknown")
    return [f for f, _ in found]


class _Model:
    """What the closed forms need of a reduction and, when at hand, of its records."""

    def __init__(self, reduction, loaded, rerun):
        import numpy as np

        from accelcal.methods.response.stepped import METHOD
        from accelcal.rigs.shaker_response import ReferenceTable

        est = reduction.estimate
        self.freq = dict(zip(est.names, _frequencies(reduction), strict=True))
        self.value = dict(zip(est.names, np.asarray(est.values, dtype=complex).tolist(),
                              strict=True))
        own = reduction.assumed("reference") != "given"
        meta = loaded[0].metadata if loaded else {}
        self.table = (ReferenceTable.from_dict(meta["reference"]) if own and loaded
                      and "reference" in meta else None)
        self.rerun = rerun if reduction.method == METHOD else None  # the sine fits'
        self._slopes = None
        self._fits = None

    def slope_dut(self, name: str) -> complex:
        """``d ln S / df`` of the DUT at the point's frequency, from the points (1/Hz)."""
        import numpy as np

        if self._slopes is None:
            freqs = sorted(set(self.freq.values()))
            logs = [np.mean([np.log(v) for n, v in self.value.items() if self.freq[n] == f])
                    for f in freqs]
            mag, phase = np.real(logs), np.unwrap(np.imag(logs))
            if len(freqs) < 2:
                slope = np.zeros(len(freqs), dtype=complex)
            else:
                x = np.log(freqs)  # a response is smoother against log f
                slope = (np.gradient(mag, x) + 1j * np.gradient(phase, x)) / np.asarray(freqs)
            self._slopes = dict(zip(freqs, slope.tolist(), strict=True))
        return self._slopes[self.freq[name]]

    def slope_ref(self, f: float) -> complex:
        """``d ln S_ref / df`` of the reference's table at ``f`` (0 without it), 1/Hz."""
        import numpy as np

        if self.table is None:
            return 0.0j
        fr = np.asarray(self.table.frequency_hz)
        h = 1e-4 * f
        lo, hi = max(f - h, fr[0]), min(f + h, fr[-1])
        s_lo, s_hi = self.table.sensitivity([lo, hi])
        return complex(np.log(s_hi / s_lo) / (hi - lo))

    def fit_response(self, name: str) -> complex:
        """``d ln S / d f_stated`` of the re-run reduction (0 without the data), 1/Hz."""
        import numpy as np

        if self.rerun is None:
            return 0.0j
        if self._fits is None:
            plus, minus = (self.rerun(frequency_relative=s * STEP) for s in (1.0, -1.0))
            ratio = np.asarray(plus.estimate.values) / np.asarray(minus.estimate.values)
            # by place: a name carries its frequency, which moved
            self._fits = {n: complex(np.log(r) / (2 * STEP * self.freq[n]))
                          for n, r in zip(self.freq, ratio, strict=True)}
        return self._fits.get(name, 0.0j)


def _reference_sensitivity(model: _Model):
    def per_row(row, std, lab):
        f = model.freq[row.label]
        table = model.table
        c_lab = 100.0 * std.factor("1") if std.dimension == "relative" else 100.0 / std.value
        if table is None or not len(table.magnitude_U):
            return std, (c_lab if row.part == "magnitude" else 0.0)
        import numpy as np

        mag = float(np.abs(table.sensitivity(f)[0]))
        rel = float(np.interp(f, table.frequency_hz, table.magnitude_U)) / TABLE_K / mag
        where = f"{std.certificate or 'reference table'}, table at {f:g} Hz"
        source = f"U = {rel * TABLE_K * 100:.3g} % (k = {TABLE_K:g}) at {f:g} Hz"
        if std.dimension == "sensitivity":
            from accelcal.budget.lab import UNITS

            value = mag / UNITS["sensitivity"][std.unit]
            here = dataclasses.replace(std, value=value, u=rel * value, certificate=where,
                                       source=source)
            c = 100.0 / value
        else:
            here = dataclasses.replace(std, value=0.0, unit="%", u=100.0 * rel,
                                       certificate=where, source=source)
            c = 1.0
        return here, (c if row.part == "magnitude" else 0.0)

    return per_row


def _reference_phase(model: _Model):
    def per_row(row, std, lab):
        f = model.freq[row.label]
        table = model.table
        c = std.factor("deg") if row.part == "phase" else 0.0
        if table is None or not len(table.phase_U):
            return std, c
        import numpy as np

        phase = float(np.interp(f, table.frequency_hz, table.phase_deg))
        u = float(np.interp(f, table.frequency_hz, table.phase_U)) / TABLE_K
        per = 1.0 / std.factor("deg")  # lab unit per deg
        here = dataclasses.replace(
            std, value=phase * per, u=u * per, source=f"U = {u * TABLE_K:.3g} deg (k = "
            f"{TABLE_K:g}) at {f:g} Hz", certificate=f"{std.certificate or 'reference table'}"
            f", table at {f:g} Hz")
        return here, c

    return per_row


def _temperature(row, std, lab):
    alpha = _declared(lab, "sensitivity_tc", "1/degC", None)
    if alpha is None:
        return "the DUT's sensitivity temperature coefficient (sensitivity_tc) is not declared"
    return std, (100.0 * alpha * std.factor("degC") if row.part == "magnitude" else 0.0)


def _temperature_coefficient(row, std, lab):
    nominal = float(lab.environment.get("temperature_degC", 23.0))
    dt = _declared(lab, "sensor_temperature", "degC", nominal) - nominal
    return std, (100.0 * dt * std.factor("1/degC") if row.part == "magnitude" else 0.0)


def _transverse_motion(row, std, lab):
    s_t = _declared(lab, "transverse_sensitivity", "1", None)
    if s_t is None:
        return "the DUT's transverse sensitivity (transverse_sensitivity) is not declared"
    return std, _part(row, s_t, s_t) * std.factor("1")


def _transverse_sensitivity(row, std, lab):
    tau = _declared(lab, "transverse_motion", "1")
    return std, _part(row, tau, tau) * std.factor("1")


def _relative_motion(row, std) -> float:
    return _part(row, 1.0, 1.0) * std.factor("1")


def _gain_mismatch(row, std) -> float:
    return 100.0 * std.factor("1") if row.part == "magnitude" else 0.0


def _delay_mismatch(model: _Model):
    def analytic(row, std) -> float:
        f = model.freq[row.label]
        return -360.0 * f * std.factor("s") if row.part == "phase" else 0.0

    return analytic


def _no_distortion(row, std) -> float:
    return 0.0


def _frequency(model: _Model):
    def per_row(row, std, lab):
        f = model.freq[row.label]
        dlog = model.slope_dut(row.label) - (
            model.fit_response(row.label) if model.rerun else model.slope_ref(f))
        per_hz = _part(row, dlog.real, dlog.imag)
        return std, per_hz * (f * std.factor("1") if std.dimension == "relative" else
                              std.factor("Hz"))

    return per_row


def harmonics(record, distortion: float):
    """The record with 2nd and 3rd harmonics of ``distortion`` of each step's amplitude added.

    Each channel's harmonics take its step's amplitude (``sqrt 2`` times its
    standard deviation) and the time origin of the record's ``t``.
    """
    import numpy as np

    if not distortion:
        return record
    ref, dut = np.array(record.ref, dtype=float), np.array(record.dut, dtype=float)
    for f, sl in zip(record.frequencies, record.steps, strict=True):
        w = 2.0 * np.pi * float(f) * np.asarray(record.t[sl], dtype=float)
        shape = distortion * (np.sin(2 * w) + np.sin(3 * w))
        for channel in (ref, dut):
            channel[sl] += math.sqrt(2.0) * np.std(channel[sl]) * shape
    return dataclasses.replace(record, ref=ref, dut=dut)


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of response records.

    Without the records (None or empty) the closed forms alone.
    """
    from os import PathLike

    from accelcal.budget.engine import DataModel
    from accelcal.methods.response.broadband import METHOD as BROADBAND
    from accelcal.methods.response.model import METHOD as FIT
    from accelcal.methods.response.stepped import METHOD

    if reduction.method == FIT:  # the inputs through the points it was fitted to
        from accelcal.methods.response.budget_fit import data_model as of_fit

        return of_fit(reduction, records, data_model)
    if reduction.method not in (METHOD, BROADBAND):
        from accelcal.catalog import method

        return DataModel(None, 0, "V", per_row=dict.fromkeys(
            method("response").budget_inputs, _not_of("an input of the comparison",
                                                      reduction.method)))
    analytic = {"daq_gain_mismatch": _gain_mismatch, "relative_motion": _relative_motion}
    per_row = {"sensor_temperature": _temperature, "sensitivity_tc": _temperature_coefficient,
               "transverse_motion": _transverse_motion,
               "transverse_sensitivity": _transverse_sensitivity}
    if records is None or (isinstance(records, list | tuple) and not records):
        model = _Model(reduction, (), None)
        return DataModel(None, 0, "V", analytic=analytic | {
            "distortion": _no_distortion, "daq_delay_mismatch": _delay_mismatch(model)},
            per_row=per_row | _table_inputs(model))
    import numpy as np

    from accelcal.budget.engine import bowed
    from accelcal.io.formats.response import read
    from accelcal.methods.response import reduce

    items = records if isinstance(records, list | tuple) else [records]
    loaded = [read(r) if isinstance(r, str | PathLike) else r for r in items]
    reference_frequency = reduction.assumed("reference_frequency")

    def rerun(*, gain=0.0, linearity=0.0, frequency_relative=0.0, distortion=0.0):
        moved = [harmonics(dataclasses.replace(
            r, ref=bowed(np.asarray(r.ref) * (1 + gain), linearity),
            dut=bowed(np.asarray(r.dut) * (1 + gain), linearity),
            frequency=np.asarray(r.frequency) * (1 + frequency_relative)),
            distortion) for r in loaded]
        return reduce(moved, reference_frequency=reference_frequency)

    model = _Model(reduction, loaded, rerun)
    if reduction.method == BROADBAND:  # no sine, no harmonics of it
        per_row["distortion"] = _not_of("an input of the stepped sine", BROADBAND)
    return DataModel(rerun, 0, loaded[0].output_unit,
                     analytic=analytic | {"daq_delay_mismatch": _delay_mismatch(model)},
                     per_row=per_row | _table_inputs(model),
                     parameters={"distortion": {"relative": ("distortion", "1")}})


def _not_of(what: str, name: str):
    def per_row(row, std, lab):
        return f"{what}, not of {name}"

    return per_row


def _table_inputs(model: _Model) -> dict:
    return {"reference_sensitivity": _reference_sensitivity(model),
            "reference_phase": _reference_phase(model), "frequency": _frequency(model)}
