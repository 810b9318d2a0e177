"""Frequency-response records: files of kind ``response`` and their type :class:`ResponseRecord`.

A record file (see :mod:`accelcal.io.records`) of kind ``response`` holds a
stepped-sine comparison on a shaker (ISO 16063-21): at each step the
shaker vibrates at one frequency and amplitude, and the reference
accelerometer and the device under test (DUT) are sampled together.
Columns, one row per sample, rows of a step contiguous:

``step`` (-)
    Index of the step, 0 .. S-1.
``frequency`` (Hz)
    The step's excitation frequency (the same on every row of a step).
``t`` (s)
    Sample time from the start of the step's record.
``ref``, ``dut`` (V, or the DUT's output unit)
    The two channels: the reference's output (V) and the DUT's. A laser
    record's ``ref`` is the interferometer's in-phase signal (V), a gravity
    record's the rotation table's encoder angle (rad).
``quadrature`` (V, laser records only)
    The interferometer's quadrature signal.

Metadata fields: ``sample_rate_hz``, ``output_unit`` (the DUT's: ``V``,
``mV`` or ``mA``), ``amplitudes_g`` (one per step, informative), and
optionally ``reference`` (the reference's certificate: ``frequency_hz``,
``magnitude`` in V/g, ``phase_deg`` and their expanded uncertainties
``magnitude_U``, ``phase_U``, k = 2, as lists), ``daq`` (the DAQ's known
channel mismatch, DUT over reference: ``gain_ratio`` and ``delay_s``),
``true`` (the DUT's transfer function a simulation used: ``S0``, ``fn_hz``,
``zeta``, ``pole_hz``, ``delay_s``), ``simulated``, ``seed``, ``noise_v``,
``excitation`` (how the record was excited, :data:`EXCITATIONS`: an object
of ``kind`` and its settings; absent for a stepped sine), and the
laboratory fields ``serial``, ``operator``, ``date``. A broadband record
(``random`` or ``swept``) is one step whose ``frequency`` is 0 (random) or
the sweep's instantaneous frequency.

The simulator is :mod:`accelcal.rigs.shaker_response`; the method,
:mod:`accelcal.methods.response`.

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Methods for the calibration of vibration
   and shock transducers, Part 21: Vibration calibration by comparison to a
   reference transducer.
"""

from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats import ImportLayout
from accelcal.io.lab_metadata import LabInfo, check_lab_metadata
from accelcal.io.record_gaps import repair_gaps
from accelcal.io.records import read_record, write_record
from accelcal.validation import shown

KIND = "response"
"""Record-file kind of stepped-sine frequency-response records."""

IMPORT = ImportLayout(time=True, restart="step", outputs="input", fixed_names=False,
                      states=("output_unit", "sample_rate_hz"))
"""How a recording that holds the record's columns (``step``, ``frequency``, ``ref``,
``dut``) is read. A lab's two-channel recording, which holds no step or frequency,
is imported by :mod:`accelcal.methods.response.importer` (``accelcal import --kind
response``), which finds the steps and their frequencies."""

OUTPUT_UNITS = ("V", "mV", "mA")
"""Units of the DUT's channel."""

COLUMNS = ("step", "frequency", "t", "ref", "dut")
"""The record's columns, in order."""

QUADRATURE = "quadrature"
"""The optional column of a laser record: the interferometer's quadrature signal, V."""

EXCITATIONS = ("stepped", "random", "swept", "laser", "gravity")
"""Kinds of the ``excitation`` metadata (``stepped`` when absent)."""

REFERENCE_KEYS = ("frequency_hz", "magnitude", "phase_deg", "magnitude_U", "phase_U")
"""Lists of a reference certificate table (``magnitude`` in V/g, phase in deg, U at k = 2)."""

_RESERVED = ("format_version", "kind", "units", "sample_rate_hz", "output_unit")

MAX_VALUE = 1e9
"""Largest magnitude of a sample, frequency or rate read: beyond it a cell is corrupt."""


@dataclass(frozen=True)
class ResponseRecord:
    """A stepped-sine comparison: two channels per step.

    Attributes
    ----------
    step : numpy.ndarray of int, shape (n,)
        Step index of each sample.
    frequency : numpy.ndarray, shape (n,)
        Excitation frequency of each sample's step, Hz.
    t : numpy.ndarray, shape (n,)
        Time from the start of the step, s.
    ref, dut : numpy.ndarray, shape (n,)
        Reference channel (V) and DUT channel (``output_unit``).
    sample_rate_hz : float
        Sample rate, Hz.
    output_unit : str
        Unit of the DUT channel (:data:`OUTPUT_UNITS`).
    metadata : dict
        The other metadata (``reference``, ``daq``, ``true``, ``amplitudes_g``,
        laboratory fields), JSON-ready.
    """

    step: np.ndarray
    frequency: np.ndarray
    t: np.ndarray
    ref: np.ndarray
    dut: np.ndarray
    sample_rate_hz: float
    output_unit: str = "V"
    metadata: dict = field(default_factory=dict)
    quadrature: np.ndarray | None = None

    def __post_init__(self) -> None:
        names = (*COLUMNS, *((QUADRATURE,) if self.quadrature is not None else ()))
        arrays = {n: np.array(getattr(self, n), dtype=float).reshape(-1) for n in names}
        if len({a.size for a in arrays.values()}) != 1:
            raise AccelcalError("a response record needs columns step, frequency, t, ref, dut "
                                "(and quadrature, if given) of one length")
        check_header(self.sample_rate_hz, self.output_unit, "response record")
        for name, a in arrays.items():
            bad = np.flatnonzero(~(np.abs(a) <= MAX_VALUE))
            if bad.size:
                raise AccelcalError(f"response record: column {name} row {int(bad[0]) + 1} = "
                                    f"{a[bad[0]]:.6g} is not a finite value up to "
                                    f"{MAX_VALUE:g}; is the file corrupt?")
        step = arrays.pop("step")
        if np.any(step != np.round(step)) or np.any(step < 0) or np.any(np.diff(step) < 0):
            raise AccelcalError("response record: step must be whole numbers from 0, "
                                "non-decreasing (rows of a step contiguous)")
        step = step.astype(int)
        step.setflags(write=False)
        object.__setattr__(self, "step", step)
        for name, a in arrays.items():
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def steps(self) -> list[slice]:
        """The rows of each step, in order."""
        edges = np.flatnonzero(np.diff(self.step)) + 1
        bounds = [0, *edges.tolist(), self.step.size]
        return [slice(a, b) for a, b in pairwise(bounds)]

    @property
    def frequencies(self) -> np.ndarray:
        """Frequency of each step, Hz."""
        return np.array([self.frequency[s.start] for s in self.steps])

    @property
    def excitation(self) -> str:
        """The kind of excitation (:data:`EXCITATIONS`; ``stepped`` when not stated)."""
        return (self.metadata.get("excitation") or {}).get("kind", "stepped")

    @property
    def lab(self) -> LabInfo:
        """The laboratory metadata (serial, operator, date)."""
        return check_lab_metadata(self.metadata, "response record")


def check_header(rate, unit, where) -> None:
    """Check a response record's ``sample_rate_hz`` (positive, finite) and ``output_unit``."""
    ok = isinstance(rate, int | float) and not isinstance(rate, bool) and 0 < rate < MAX_VALUE
    if not ok:
        raise AccelcalError(f"{where}: sample_rate_hz {shown(rate)} must be a positive number "
                            "of Hz")
    if not isinstance(unit, str) or unit not in OUTPUT_UNITS:
        raise AccelcalError(f"{where}: output_unit {shown(unit)} is not one of "
                            f"{', '.join(OUTPUT_UNITS)}")


def _numbers(value, where: str, what: str, size: int | None = None) -> list[float]:
    """A list of finite numbers up to :data:`MAX_VALUE` (of ``size`` entries, if given)."""
    ok = isinstance(value, list) and all(
        isinstance(x, int | float) and not isinstance(x, bool) and abs(x) <= MAX_VALUE
        for x in value)
    if not ok or (size is not None and len(value) != size):
        count = f"{size} " if size is not None else ""
        raise AccelcalError(f"{where}: {what} must be a list of {count}finite numbers; got "
                            f"{shown(value)}")
    return [float(x) for x in value]


def check_metadata(meta: dict, where, steps: int) -> None:
    """Check the optional ``amplitudes_g``, ``daq`` and ``reference`` of a record's metadata.

    Raises
    ------
    AccelcalError
        Naming the file and the field: ``amplitudes_g`` not one positive
        number per step; ``daq`` not an object of a positive ``gain_ratio``
        and a ``delay_s`` within 1 s; ``reference`` not an object of lists of
        finite numbers of one length (at least two), ``frequency_hz`` and
        ``magnitude`` positive.
    """
    if "amplitudes_g" in meta:
        amps = _numbers(meta["amplitudes_g"], where, "amplitudes_g (one per step)", steps)
        if not all(a > 0 for a in amps):
            raise AccelcalError(f"{where}: amplitudes_g must be positive (g)")
    if "daq" in meta:
        daq = meta["daq"]
        if not isinstance(daq, dict) or not set(daq) <= {"gain_ratio", "delay_s"}:
            raise AccelcalError(f"{where}: daq must be an object of gain_ratio and delay_s; "
                                f"got {shown(daq)}")
        gain, delay = _numbers([daq.get("gain_ratio", 1.0), daq.get("delay_s", 0.0)], where,
                               "daq's gain_ratio and delay_s")
        if not (0 < gain <= 1e6 and abs(delay) <= 1.0):
            raise AccelcalError(f"{where}: daq gain_ratio must be in (0, 1e6] and delay_s "
                                "within 1 s")
    if "excitation" in meta:
        exc = meta["excitation"]
        if not isinstance(exc, dict) or exc.get("kind") not in EXCITATIONS:
            raise AccelcalError(f"{where}: excitation must be an object whose kind is one of "
                                f"{', '.join(EXCITATIONS)}; got {shown(exc)}")
    if "reference" in meta:
        ref = meta["reference"]
        keys = [k for k in REFERENCE_KEYS if isinstance(ref, dict) and k in ref]
        if not isinstance(ref, dict) or not set(REFERENCE_KEYS[:3]) <= set(keys) or \
                not set(ref) <= set(REFERENCE_KEYS):
            raise AccelcalError(f"{where}: reference must be an object of lists "
                                f"{', '.join(REFERENCE_KEYS[:3])} (and optionally "
                                f"{', '.join(REFERENCE_KEYS[3:])})")
        size = len(ref["frequency_hz"]) if isinstance(ref["frequency_hz"], list) else None
        cols = {k: _numbers(ref[k], where, f"reference {k}", size) for k in keys}
        if size is None or size < 2 or not all(f > 0 for f in cols["frequency_hz"]) or \
                not all(m > 0 for m in cols["magnitude"]):
            raise AccelcalError(f"{where}: reference needs at least two positive frequencies "
                                "and positive magnitudes")


def write(path, data: ResponseRecord) -> None:
    """Write a response record file (atomically; CSV, or Parquet for ``.parquet``)."""
    ref_unit = "rad" if data.excitation == "gravity" else "V"
    units = {"step": "-", "frequency": "Hz", "t": "s", "ref": ref_unit, "dut": data.output_unit}
    columns = {c: getattr(data, c) for c in COLUMNS}
    if data.quadrature is not None:
        units[QUADRATURE] = "V"
        columns[QUADRATURE] = data.quadrature
    meta = {"units": units, "sample_rate_hz": float(data.sample_rate_hz),
            "output_unit": data.output_unit,
            **{k: v for k, v in data.metadata.items() if k not in _RESERVED}}
    write_record(path, KIND, meta, columns)


NOT_FILLED = ("a step's sine is not linear between samples (a filled sample would bias its "
              "fit)")
"""Why a gap inside a step is never filled."""


def read(path, *, gaps: str = "refuse", max_fill: int = 5) -> ResponseRecord:
    """Read and validate a response record file.

    ``gaps``: a jump of the time column inside a step (over 1.5 sample
    intervals at ``sample_rate_hz``) is a gap, refused or, with ``split``,
    cut (the step's longest piece of consecutive samples kept:
    :func:`accelcal.io.record_gaps.repair_gaps`); never filled (a sine is not
    linear between samples); a jump between steps is harmless. What was done
    is in ``metadata["repairs"]``.

    Raises
    ------
    AccelcalError
        Naming the file: see :func:`accelcal.io.records.read_record`; a bad
        rate or unit, a corrupt value, a step column out of order, malformed
        laboratory metadata, ``amplitudes_g``, ``daq`` or ``reference``
        (:func:`check_metadata`).
    """
    meta, cols = read_record(path, KIND, required_metadata=("sample_rate_hz", "output_unit"),
                             required_columns=COLUMNS)
    check_header(meta["sample_rate_hz"], meta["output_unit"], path)
    check_lab_metadata(meta, path)
    cols, repairs = repair_gaps(cols, where=path, keys=("step",),
                                interval=1.0 / meta["sample_rate_hz"], gaps=gaps,
                                max_fill=max_fill, keep="longest", what="step",
                                fillable=NOT_FILLED)
    if repairs:
        meta = {**meta, "repairs": repairs}
    steps = int(np.count_nonzero(np.diff(cols["step"]))) + 1 if cols["step"].size else 0
    check_metadata(meta, path, steps)
    try:
        return ResponseRecord(**{c: cols[c] for c in COLUMNS},
                              sample_rate_hz=meta["sample_rate_hz"],
                              output_unit=meta["output_unit"],
                              metadata={k: v for k, v in meta.items() if k not in _RESERVED},
                              quadrature=cols.get(QUADRATURE))
    except AccelcalError as exc:
        raise AccelcalError(f"{path}: {exc}") from None
