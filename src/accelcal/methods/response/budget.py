"""The frequency response's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

By comparison (ISO 16063-21 [ISO16063-21]_) the DUT's complex sensitivity
at each step is the reference's times the ratio of the two channels'
phasors, ``S = S_ref V_dut / V_ref``. Each step's magnitude (in % of its
estimate) and phase (deg) get a budget. The lab's inputs enter

- in closed form: the reference's sensitivity, ``c = 1`` in % per % of
  ``S_ref`` on the magnitude (0 on the phase), and its phase, ``c = 1`` on
  the phase (0 on the magnitude);
- through the data, re-run: the excitation frequency (every step's
  frequency, relative or in Hz, as the sine fits use it), the DAQ's gain
  and linearity on both channels (the same DAQ: a common gain cancels in
  the ratio, as the re-run shows).

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Vibration calibration by comparison to a
   reference transducer, annex A (uncertainty budget).
"""


def _reference_sensitivity(row, std) -> float:
    """% of S per unit of the lab's S_ref on the magnitude (per % when relative)."""
    if row.part != "magnitude":
        return 0.0
    return 100.0 * std.factor("1") if std.dimension == "relative" else 100.0 / std.value


def _reference_phase(row, std) -> float:
    """The phase's degrees per unit of the lab's reference phase."""
    return std.factor("deg") if row.part == "phase" else 0.0


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of response records (None without them)."""
    from accelcal.budget.engine import DataModel

    analytic = {"reference_sensitivity": _reference_sensitivity,
                "reference_phase": _reference_phase}
    if records is None or (isinstance(records, list | tuple) and not records):
        return DataModel(None, 0, "V", analytic=analytic)
    import dataclasses
    from os import PathLike

    import numpy as np

    from accelcal.budget.engine import bowed
    from accelcal.io.formats.response import read
    from accelcal.methods.response import reduce

    items = records if isinstance(records, list | tuple) else [records]
    loaded = [read(r) if isinstance(r, str | PathLike) else r for r in items]
    reference_frequency = reduction.assumed("reference_frequency")

    def rerun(*, gain=0.0, linearity=0.0, frequency=0.0, frequency_relative=0.0):
        moved = [dataclasses.replace(
            r, ref=bowed(np.asarray(r.ref) * (1 + gain), linearity),
            dut=bowed(np.asarray(r.dut) * (1 + gain), linearity),
            frequency=(np.asarray(r.frequency) + frequency) * (1 + frequency_relative))
            for r in loaded]
        return reduce(moved, reference_frequency=reference_frequency)

    return DataModel(rerun, 0, loaded[0].output_unit, analytic=analytic, parameters={
        "frequency": {"frequency": ("frequency", "Hz"), "relative": ("frequency_relative", "1")}})
