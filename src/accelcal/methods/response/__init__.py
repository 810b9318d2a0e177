"""Frequency response: complex sensitivity against frequency by comparison, and its model.

The package:

:mod:`~accelcal.methods.response.stepped`
    :func:`reduce_stepped`: a stepped-sine comparison with a reference
    accelerometer (ISO 16063-21) to one complex coefficient ``S(f Hz)`` per
    step (family ``"response"``, method ``"response/comparison"``), with
    the covariance of its ``[Re, Im]``; :func:`response_rows`, magnitude
    and phase with their uncertainties and the deviation from the reference
    frequency in % and dB.
:mod:`~accelcal.methods.response.model`
    :func:`fit_model`: weighted complex least squares of the force-rebalance
    transfer function (``S0``, ``fn``, ``zeta``, optionally an extra pole
    and a delay; method ``"response/model-fit"``); :func:`derived`, the
    -3 dB bandwidth, the resonance and the phase at stated frequencies.
:mod:`~accelcal.methods.response.figures`
    :func:`figures`: the Bode figure with uncertainty bands and the model.

Record files of kind ``response`` are :mod:`accelcal.io.formats.response`;
the simulator is :mod:`accelcal.rigs.shaker_response`. The verbs:
:func:`simulate` (the rig) and :func:`reduce` (records or their files to the
stepped-sine reduction, as ``accelcal response reduce`` does).

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Vibration calibration by comparison to a
   reference transducer.
"""

from accelcal.methods import ReportText
from accelcal.methods.response.figures import figures
from accelcal.methods.response.model import derived, fit_model, fit_rows
from accelcal.methods.response.stepped import FAMILY, METHOD, reduce_stepped, response_rows

__all__ = ["ERRATA", "FAMILY", "METHOD", "derived", "figures", "fit_model", "fit_rows",
           "read_reference", "reduce", "reduce_stepped", "report_text", "response_rows",
           "simulate"]

ERRATA = ()
"""No corrections of the references are shown."""

MAX_REFERENCE_BYTES = 2**20
"""Largest reference certificate table read (1 MiB: tens of thousands of rows)."""


def report_text(reduction) -> ReportText:
    """Title and summary of a frequency response's report section."""
    prov = reduction.provenance
    if reduction.method == METHOD:
        rows = response_rows(reduction)
        band = f"{rows[0]['frequency_hz']:g}-{rows[-1]['frequency_hz']:g} Hz"
        worst = max(rows, key=lambda r: abs(r["deviation_pct"]))
        summary = (f"Stepped-sine comparison with a reference accelerometer (ISO 16063-21): "
                   f"{prov.get('steps', len(rows))} steps over {band}; both channels fitted "
                   "with a sine of the step's frequency on whole periods, the DUT's complex "
                   "sensitivity as the reference's times the phasors' ratio. Largest deviation "
                   f"from {reduction.assumed('reference_frequency'):g} Hz: "
                   f"{worst['deviation_pct']:.3g} % at {worst['frequency_hz']:g} Hz. The "
                   "reference certificate's own uncertainty is not included.")
        sensor = "Complex sensitivity (magnitude and phase) at each step."
    else:
        fitted = {r["coefficient"]: r for r in fit_rows(reduction)}
        bw = fitted["f_3dB"]
        summary = (f"Transfer function {reduction.assumed('model')} fitted by weighted "
                   f"complex least squares to {prov.get('points', 0)} points; -3 dB bandwidth "
                   f"{bw['estimate']:.5g} ± {bw['std']:.2g} Hz; Birge ratio "
                   f"{reduction.assumed('birge_ratio'):.3g}.")
        sensor = "Force-rebalance transfer function fitted to the frequency response."
    return ReportText(title="frequency response (comparison, stepped sine)", summary=summary,
                      sensor_summary=sensor)


def read_reference(path):
    """A reference certificate from a CSV table.

    Columns ``frequency_hz, magnitude, phase_deg`` (and optionally
    ``magnitude_U``, ``phase_U``), magnitude in V/g, phase in deg.

    Returns
    -------
    accelcal.rigs.shaker_response.ReferenceTable

    Raises
    ------
    AccelcalError
        Naming the file: missing columns, values that are not numbers,
        frequencies not increasing.
    """
    import csv
    from pathlib import Path

    from accelcal.errors import AccelcalError
    from accelcal.io.limits import read_bounded
    from accelcal.rigs.shaker_response import ReferenceTable
    from accelcal.validation import shown_path

    path = Path(path)
    try:
        text = read_bounded(path, MAX_REFERENCE_BYTES, "reference table").decode("utf-8")
        lines = [row for row in text.splitlines() if not row.startswith("#")]
        rows = list(csv.DictReader(lines))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise AccelcalError(f"cannot read {shown_path(path)}: {exc.__class__.__name__}",
                            parameter="reference") from None
    columns = {k: [r.get(k) for r in rows] for k in
               ("frequency_hz", "magnitude", "phase_deg", "magnitude_U", "phase_U")
               if rows and k in rows[0]}
    try:
        return ReferenceTable.from_dict(columns)
    except AccelcalError as exc:
        raise AccelcalError(f"{shown_path(path)}: {exc.args[0] if exc.args else exc}",
                            parameter="reference") from None


def simulate(*, seed=0, dut=None, unit: str = "V", **settings):
    """A simulated stepped-sine record: :func:`accelcal.rigs.shaker_response.simulate`.

    ``dut`` a :class:`~accelcal.rigs.shaker_response.DutResponse`; ``settings``
    the rig's fields (``frequencies``, ``amplitudes``, ``sample_rate``,
    ``periods``, ``reference``, ``gain_ratio``, ``delay_s``, ``distortion``,
    ``noise``); ``seed`` an int, SeedSequence or Generator.
    """
    from accelcal.rigs.shaker_response import simulate as rig_simulate

    return rig_simulate(dut, seed=seed, unit=unit, **settings)


def reduce(records, *, reference=None, reference_frequency=None):
    """The stepped-sine comparison of records or their files, as ``accelcal response reduce``.

    Parameters
    ----------
    records : path-like, ResponseRecord, or a sequence of them
        Stepped-sine records or their files.
    reference : path-like or ReferenceTable, optional
        The reference's certificate (a CSV table); default each record's own.
    reference_frequency : float, optional
        Frequency of the deviations, Hz.

    Returns
    -------
    accelcal.results.Reduction
        Method ``response/comparison`` (:func:`reduce_stepped`).
    """
    from os import PathLike

    from accelcal.io.formats.response import read

    items = records if isinstance(records, list | tuple) else [records]
    loaded = [read(r) if isinstance(r, str | PathLike) else r for r in items]
    if isinstance(reference, str | PathLike):
        reference = read_reference(reference)
    return reduce_stepped(loaded, reference, reference_frequency=reference_frequency)
