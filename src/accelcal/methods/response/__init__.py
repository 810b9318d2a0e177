"""Frequency response: complex sensitivity against frequency by comparison, and its model.

The package:

:mod:`~accelcal.methods.response.stepped`
    :func:`reduce_stepped`: a stepped-sine comparison with a reference
    accelerometer (ISO 16063-21) to one complex coefficient ``S(f Hz)`` per
    step (family ``"response"``, method ``"response/comparison"``), with
    the covariance of its ``[Re, Im]``; :func:`response_rows`, magnitude
    and phase with their uncertainties and the deviation from the reference
    frequency in % and dB.
:mod:`~accelcal.methods.response.broadband`
    :func:`reduce_broadband`: the comparison with random or swept excitation,
    H1 from Welch cross-spectra streamed block by block, with the random
    error of magnitude and phase from the coherence (``response/broadband``).
:mod:`~accelcal.methods.response.primary`
    :func:`reduce_laser` (ISO 16063-11 method 3: Heydemann-corrected
    interferometer, ``response/laser``) and :func:`reduce_gravity` (ISO
    16063-16: rotation in gravity, tied to the static scale factor,
    ``response/gravity``).
:mod:`~accelcal.methods.response.plan`
    :func:`plan`: the periods (stepped sine) or averages (broadband) that
    give a stated uncertainty of magnitude and phase at a given SNR.
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
from accelcal.methods.response.broadband import reduce_broadband
from accelcal.methods.response.figures import figures
from accelcal.methods.response.model import derived, fit_model, fit_rows
from accelcal.methods.response.plan import plan
from accelcal.methods.response.primary import GRAVITY, LASER, reduce_gravity, reduce_laser
from accelcal.methods.response.stepped import FAMILY, METHOD, reduce_stepped, response_rows

__all__ = ["ERRATA", "FAMILY", "METHOD", "METHODS", "derived", "figures", "fit_model",
           "fit_rows", "from_inputs", "plan", "read_reference", "reduce", "reduce_broadband",
           "reduce_gravity", "reduce_laser", "reduce_stepped", "report_text", "response_rows",
           "simulate"]

METHODS = ("stepped", "broadband", "laser", "gravity")
"""The routes of ``reduce(..., method=)``: the excitation kinds each takes."""

_KINDS = {"stepped": ("stepped",), "broadband": ("random", "swept"), "laser": ("laser",),
          "gravity": ("gravity",)}

_TITLES = {METHOD: "comparison, stepped sine", "response/broadband":
           "comparison, broadband excitation", LASER: "primary, laser interferometry",
           GRAVITY: "gravity, rotating table"}

ERRATA = ()
"""No corrections of the references are shown."""

MAX_REFERENCE_BYTES = 2**20
"""Largest reference certificate table read (1 MiB: tens of thousands of rows)."""


def report_text(reduction) -> ReportText:
    """Title and summary of a frequency response's report section."""
    prov = reduction.provenance
    if reduction.method in _TITLES:
        rows = response_rows(reduction)
        band = f"{rows[0]['frequency_hz']:g}-{rows[-1]['frequency_hz']:g} Hz"
        worst = max(rows, key=lambda r: abs(r["deviation_pct"]))
        summary = (f"{reduction.notes[0]} {prov.get('steps', len(rows))} points over {band}. "
                   "Largest deviation from "
                   f"{reduction.assumed('reference_frequency'):g} Hz: "
                   f"{worst['deviation_pct']:.3g} % at {worst['frequency_hz']:g} Hz. A "
                   "reference certificate's own uncertainty is not included.")
        sensor = "Complex sensitivity (magnitude and phase) at each point."
    else:
        fitted = {r["coefficient"]: r for r in fit_rows(reduction)}
        bw = fitted["f_3dB"]
        summary = (f"Transfer function {reduction.assumed('model')} fitted by weighted "
                   f"complex least squares to {prov.get('points', 0)} points; -3 dB bandwidth "
                   f"{bw['estimate']:.5g} ± {bw['std']:.2g} Hz; Birge ratio "
                   f"{reduction.assumed('birge_ratio'):.3g}.")
        sensor = "Force-rebalance transfer function fitted to the frequency response."
    title = _TITLES.get(reduction.method, "model fit")
    return ReportText(title=f"frequency response ({title})", summary=summary,
                      sensor_summary=sensor)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.methods.response.model import METHOD as FIT

    if record.method == FIT:
        return [(fit_model(reduce(files[0])), {})]
    if record.method in _TITLES:
        red = reduce(files[0])
        return [(red, {"fit": fit_model(red)})]
    return []


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


def excitation_of(item) -> str:
    """The excitation kind of a record or of a record file (its metadata alone read)."""
    from os import PathLike

    if not isinstance(item, str | PathLike):
        return item.excitation
    from accelcal.io.recordings.sources import open_source

    meta = open_source(item, "record", None).metadata
    return (meta.get("excitation") or {}).get("kind", "stepped") if isinstance(
        meta.get("excitation"), dict) else "stepped"


def reduce(records, *, method: str | None = None, reference=None, reference_frequency=None,
           segment: int | None = None, min_coherence: float | None = None,
           static_scale_factor=None, gaps: str = "refuse", max_fill: int = 5):
    """Records or their files reduced by one route, as ``accelcal response reduce``.

    Parameters
    ----------
    records : path-like, ResponseRecord, or a sequence of them
        Response records or their files.
    method : str, optional
        ``stepped``, ``broadband``, ``laser`` or ``gravity`` (:data:`METHODS`);
        default the first record's excitation's.
    reference : path-like or ReferenceTable, optional
        The reference's certificate (a CSV table); default each record's own
        (comparisons only).
    reference_frequency : float, optional
        Frequency of the deviations, Hz.
    segment, min_coherence : optional
        Broadband: Welch segment (samples) and the lowest coherence kept.
    static_scale_factor : (float, float), optional
        Gravity: the static scale factor and its standard uncertainty to tie to.
    gaps, max_fill
        A gap inside a step of a file: refused, or cut with ``"split"`` (the
        step's longest piece kept; :func:`accelcal.io.formats.response.read`);
        broadband: refused, or with ``"split"`` the Welch averages taken over
        the pieces between gaps and pooled (:func:`reduce_broadband`; never
        filled). What was done is in the provenance (``repairs``) and notes.

    Returns
    -------
    accelcal.results.Reduction
        :func:`reduce_stepped`, :func:`reduce_broadband` (one record, a file
        streamed), :func:`reduce_laser` or :func:`reduce_gravity`.

    Raises
    ------
    AccelcalError
        For a method that is not one of :data:`METHODS`, records of another
        excitation, options of another route.
    """
    from os import PathLike
    from pathlib import PurePath

    from accelcal.errors import AccelcalError
    from accelcal.io.formats.response import read

    items = list(records) if isinstance(records, list | tuple) else [records]
    if not items:
        raise AccelcalError("give at least one record", parameter="records")
    if method is None:
        method = next(m for m, kinds in _KINDS.items() if excitation_of(items[0]) in kinds)
    if method not in METHODS:
        raise AccelcalError(f"{method!r} is not one of {', '.join(METHODS)}",
                            parameter="method")
    for item in items:
        kind = excitation_of(item)
        if kind not in _KINDS[method]:
            raise AccelcalError(f"--method {method} needs {' or '.join(_KINDS[method])} "
                                f"records; {getattr(item, 'name', 'a record')} is {kind}",
                                parameter="method")
    misplaced = [name for name, value, ok in (
        ("reference", reference, method in ("stepped", "broadband")),
        ("segment", segment, method == "broadband"),
        ("min_coherence", min_coherence, method == "broadband"),
        ("static_scale_factor", static_scale_factor, method == "gravity")) if value is not None
        and not ok]
    if misplaced:
        raise AccelcalError(f"{misplaced[0]} does not apply to --method {method}",
                            parameter=misplaced[0])
    if isinstance(reference, str | PathLike):
        reference = read_reference(reference)
    if method == "broadband":
        if len(items) != 1:
            raise AccelcalError("a broadband reduction takes one record", parameter="records")
        extra = {} if min_coherence is None else {"min_coherence": min_coherence}
        return reduce_broadband(items[0], reference, segment=segment,
                                reference_frequency=reference_frequency, gaps=gaps, **extra)
    from accelcal.io.record_gaps import merged
    from accelcal.io.recordings.repairs import with_repairs

    loaded = [read(r, gaps=gaps, max_fill=max_fill) if isinstance(r, str | PathLike) else r
              for r in items]
    found = merged([(PurePath(r).name if isinstance(r, str | PathLike) else f"record {k + 1}",
                     rec.metadata.get("repairs"))
                    for k, (r, rec) in enumerate(zip(items, loaded, strict=True))])
    if method == "laser":
        return with_repairs(reduce_laser(loaded, reference_frequency=reference_frequency),
                            found)
    if method == "gravity":
        return with_repairs(reduce_gravity(loaded, static_scale_factor=static_scale_factor,
                                           reference_frequency=reference_frequency), found)
    return with_repairs(reduce_stepped(loaded, reference,
                                       reference_frequency=reference_frequency), found)
