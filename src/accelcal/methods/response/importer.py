"""Two-channel shaker recordings made into a ``response`` record (``import --kind response``).

A comparison on a shaker records the reference accelerometer (``ref``,
V) and the device under test (``dut``, V, mV or mA) together, and often
the shaker's drive or a tachometer (``drive``, any unit: it only shows the
frequency). A response record holds one step per excitation frequency
(:mod:`accelcal.io.formats.response`); the steps come

- one per file (``steps="files"``): each recording is a step, its
  frequency given or detected from the data;
- detected in one long file (``steps="detect"``): the plateaus of constant
  frequency, found by the short-time spectral peak.

Detection. The strongest spectral line of the drive channel (else of the
reference) in Hann windows of ``window_s`` seconds, half overlapping, zero
padded four times and refined by parabolic interpolation of the log
magnitude; a window whose line holds less than half its power has none.
Consecutive windows whose lines lie within one bin (``1 / window_s`` Hz) of
the plateau's first make a plateau; one window is trimmed at each end (the
changes of frequency fall there). A run no longer than those two windows is
a change of frequency (a window across two lines shows a line between
them) and is skipped: the window should be at most a quarter of the
shortest step. A step's frequency is then the
four-parameter sine fit's (IEEE 1057) on its samples, started at the
spectral peak, taken as the nominal value of :data:`NOMINAL_DIGITS`
significant digits when within :data:`NOMINAL_PPM` of it.

Checks of each step, with the rule for each: a defect that makes the
point's value wrong refuses the import (one line, nothing written):

- clipping: a run of samples at a channel's extreme longer than 0.5 % of a
  period (at least :data:`~accelcal.signal.clipping.MIN_RUN` samples;
  :func:`~accelcal.signal.clipping.clipped`);
- too few periods: fewer than ``min_periods`` whole periods;
- frequency not found: the sine at the step's frequency explains less than
  :data:`MIN_EXPLAINED` of the reference channel's variance;
- a reference certificate (``reference``) that does not cover the steps'
  frequencies.

A defect that only makes the point less certain flags it and the rest goes
on: a step *coherence* below ``min_coherence``. The step's coherence is the
fraction of the DUT channel's variance that the sine at the step's
frequency explains (the coherence of the two channels at the line when
the reference is clean); the reduction's uncertainty, from the fit's
residuals, already widens with it. Flagged steps are listed in the
record's ``flagged`` metadata and in the import's result.

References
----------
.. [ISO16063-21] ISO 16063-21:2003, sec. 6 (the comparison's steps).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3.3 (four-parameter sine fit).
.. [Harris1978] F. J. Harris, On the use of windows for harmonic analysis
   with the discrete Fourier transform, Proc. IEEE 66 (1978) 51-83.
"""

import dataclasses
import os
import tempfile
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.validation import shown_path

ROLES = ("ref", "dut", "drive")
"""Record columns a response import maps: the reference, the DUT and an optional drive."""

STEP_MODES = ("files", "detect")
"""One step per file, or the steps detected in each file."""

MIN_PERIODS = 3
"""Default fewest whole periods a step must hold."""

MIN_COHERENCE = 0.9
"""Default least step coherence; below it the step is flagged."""

MIN_EXPLAINED = 0.5
"""Least fraction of the reference channel's variance the step's sine must explain."""

WINDOW_S = 0.5
"""Default detection window, s."""

NOMINAL_PPM = 10.0
"""A detected frequency within this many ppm of a value of :data:`NOMINAL_DIGITS`
significant digits is taken as that value (the generator's setting; the clocks of
generator and DAQ differ by a few ppm)."""

NOMINAL_DIGITS = 4
"""Significant digits of a nominal step frequency."""

CLIP_PERIOD_FRACTION = 0.005
"""A clip is a run at a rail longer than this fraction of a period."""

_REF_TO_V = {"V": 1.0, "mV": 1e-3}
_DUT_UNITS = ("V", "mV", "mA")


def import_response(paths, options, *, channels: dict, out, metadata: dict | None = None,
                    frequencies=None, steps: str = "files", window_s: float = WINDOW_S,
                    min_periods: int = MIN_PERIODS, min_coherence: float = MIN_COHERENCE,
                    reference: dict | None = None) -> dict:
    """Make a response record of two-channel recordings (module docs).

    Parameters
    ----------
    paths : sequence of path-like
        The recordings (any format :func:`~accelcal.io.recordings.read_recording` reads).
    options : InputOptions
        How to read them (the channel map replaces the columns).
    channels : dict
        ``ref`` and ``dut`` (and optionally ``drive``) -> the recordings' channels.
    out : path-like
        The record to write (``.parquet``: Parquet; else CSV).
    metadata : dict, optional
        Further metadata (``serial``, ``operator`` ...).
    frequencies : sequence of float, optional
        ``steps="files"``: each file's frequency, Hz (default: detected).
    steps : str
        ``files`` or ``detect`` (:data:`STEP_MODES`).
    window_s : float
        ``detect``: the detection window, s.
    min_periods : int
        Fewest whole periods of a step.
    min_coherence : float
        Steps of lower coherence are flagged.
    reference : dict, optional
        The reference's certificate (``frequency_hz``, ``magnitude``, ``phase_deg`` ...),
        written into the record; it must cover the steps.

    Returns
    -------
    dict
        ``record``, ``kind``, ``samples``, ``columns``, ``steps`` (one entry per
        step: ``file``, ``start_s``, ``frequency_hz``, ``periods``, ``coherence``,
        ``flagged``) and ``provenance``.

    Raises
    ------
    AccelcalError
        One line: a bad map, unit or setting; a step clipped, too short, of a
        frequency not in the data; a reference that does not cover the steps.
    """
    from accelcal.io.formats import response as fmt

    paths = [Path(p) for p in paths]
    channels = _check(paths, channels, frequencies, steps, window_s=window_s,
                      min_periods=min_periods, min_coherence=min_coherence)
    out = Path(out)
    if not out.parent.is_dir():
        raise AccelcalError(f"cannot write {shown_path(out)}: directory "
                            f"{shown_path(out.parent)} does not exist", parameter="out")
    opts = dataclasses.replace(options, columns=tuple(channels.values()), refuse_gaps=True)
    found, provs, rate, unit = [], [], None, None
    for n, path in enumerate(paths):
        rec, ref, dut, drive, dut_unit = _read(path, opts, channels)
        if rate is not None and abs(rec.rate - rate) > 1e-9 * rate:
            raise AccelcalError(f"{shown_path(path)} is sampled at {rec.rate:g} Hz, the first "
                                f"file at {rate:g} Hz: a record has one rate")
        if unit is not None and dut_unit != unit:
            raise AccelcalError(f"{shown_path(path)}'s dut channel is in {dut_unit}, the first "
                                f"file's in {unit}")
        rate, unit = rec.rate, dut_unit
        provs.append(rec.provenance)
        line = drive if drive is not None else ref
        if steps == "files":
            spans = [(0, ref.size, None if frequencies is None else float(frequencies[n]))]
        else:
            spans = plateaus(line, rate, window_s=window_s, min_periods=min_periods,
                             where=shown_path(path))
        for a, b, f in spans:
            step = check_step(ref[a:b], dut[a:b], line[a:b], rate, f,
                              min_periods=min_periods,
                              where=f"{shown_path(path)}, step at {a / rate:.6g} s")
            found.append({"file": path.name, "start_s": a / rate, **step,
                          "flagged": step["coherence"] < min_coherence,
                          "ref": ref[a:b], "dut": dut[a:b]})
    if reference is not None:
        _covers(reference, [s["frequency_hz"] for s in found])
    flagged = [{"step": k, "frequency_hz": s["frequency_hz"],
                "reason": f"coherence {s['coherence']:.3g} below {min_coherence:g}"}
               for k, s in enumerate(found) if s["flagged"]]
    meta = {**(metadata or {}),
            "provenance": {"files": provs, "channel_map": channels, "steps": steps,
                           "min_periods": min_periods, "min_coherence": min_coherence,
                           **({"window_s": window_s} if steps == "detect" else {})}}
    if reference is not None:
        meta["reference"] = reference
    if flagged:
        meta["flagged"] = flagged
    record = fmt.ResponseRecord(
        step=np.concatenate([np.full(s["ref"].size, k) for k, s in enumerate(found)]),
        frequency=np.concatenate([np.full(s["ref"].size, s["frequency_hz"]) for s in found]),
        t=np.concatenate([np.arange(s["ref"].size) / rate for s in found]),
        ref=np.concatenate([s["ref"] for s in found]),
        dut=np.concatenate([s["dut"] for s in found]),
        sample_rate_hz=float(rate), output_unit=unit, metadata=meta)
    _write(out, record)
    table = [{k: v for k, v in s.items() if k not in ("ref", "dut")} for s in found]
    return {"record": str(out), "kind": fmt.KIND, "samples": int(record.step.size),
            "columns": list(fmt.COLUMNS), "steps": table, "provenance": meta["provenance"]}


def _check(paths, channels, frequencies, steps, *, window_s, min_periods, min_coherence) -> dict:
    if not paths:
        raise AccelcalError("give at least one recording")
    if not isinstance(channels, dict) or not {"ref", "dut"} <= set(channels) or \
            not set(channels) <= set(ROLES):
        raise AccelcalError("a response import maps ref and dut (and optionally drive) to the "
                            "recording's channels, e.g. ref=Shaker/Ref,dut=Shaker/DUT",
                            parameter="channels")
    if len(set(channels.values())) != len(channels):
        raise AccelcalError("the channel map names a channel twice", parameter="channels")
    if steps not in STEP_MODES:
        raise AccelcalError(f"steps {steps!r} is not one of {', '.join(STEP_MODES)}",
                            parameter="steps")
    if frequencies is not None:
        if steps != "files":
            raise AccelcalError("frequencies are given per file (one step per file); detected "
                                "steps take their frequencies from the data",
                                parameter="frequencies")
        if len(frequencies) != len(paths) or not all(0 < f < 1e9 for f in frequencies):
            raise AccelcalError(f"give one positive frequency per file ({len(paths)}), not "
                                f"{len(frequencies)}", parameter="frequencies")
    if not 0 < window_s <= 3600:
        raise AccelcalError(f"the detection window must be above 0 and up to 3600 s, got "
                            f"{window_s!r}", parameter="step_window")
    if not (isinstance(min_periods, int) and 1 <= min_periods <= 1_000_000):
        raise AccelcalError(f"min periods must be a whole number from 1, got {min_periods!r}",
                            parameter="min_periods")
    if not 0 <= min_coherence < 1:
        raise AccelcalError(f"the least coherence must be in [0, 1), got {min_coherence!r}",
                            parameter="min_coherence")
    return {k: channels[k] for k in ROLES if k in channels}


def _read(path, opts, channels):
    from accelcal.io.recordings.read import read_recording

    rec = read_recording(path, opts, need_rate=True, what="response recording")
    units = dict(zip(rec.channels, rec.units or (rec.unit,) * len(rec.channels), strict=True))
    cols = dict(zip(channels, rec.values.T, strict=True))
    ref_unit, dut_unit = units[channels["ref"]], units[channels["dut"]]
    if ref_unit not in _REF_TO_V:
        raise AccelcalError(f"{shown_path(path)}: the ref channel {channels['ref']!r} is in "
                            f"{ref_unit}; a reference's output is in V or mV", parameter="units")
    if dut_unit not in _DUT_UNITS:
        raise AccelcalError(f"{shown_path(path)}: the dut channel {channels['dut']!r} is in "
                            f"{dut_unit}, not one of {', '.join(_DUT_UNITS)}",
                            parameter="units")
    return (rec, cols["ref"] * _REF_TO_V[ref_unit], np.array(cols["dut"]), cols.get("drive"),
            dut_unit)


def spectral_peak(x, rate: float) -> tuple[float, float]:
    """The strongest line of ``x``: its frequency (Hz) and the fraction of the power it holds.

    Hann window, zero padding to four times the length, parabolic
    interpolation of the log magnitude [Harris1978]; the line's power is
    that of the three bins around the peak of the unpadded spectrum.
    """
    x = np.asarray(x, float) - np.mean(x)
    n = x.size
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft(x * w, 4 * n))
    k = int(np.argmax(spec[4:-1])) + 4  # above the lowest bin of the unpadded spectrum
    lm = np.log(spec[k - 1:k + 2] + 1e-300)
    den = lm[0] - 2 * lm[1] + lm[2]
    delta = 0.5 * (lm[0] - lm[2]) / den if den != 0 else 0.0
    coarse = np.abs(np.fft.rfft(x * w)) ** 2
    j = round(k / 4)
    total = float(coarse[1:].sum())
    share = float(coarse[max(j - 1, 1):j + 2].sum()) / total if total > 0 else 0.0
    return (k + delta) * rate / (4 * n), share


def plateaus(x, rate: float, *, window_s: float = WINDOW_S, min_periods: int = MIN_PERIODS,
             where: str = "recording") -> list[tuple[int, int, float]]:
    """The steps of constant frequency in ``x``: ``(start, stop, frequency_hz)`` (module docs).

    Raises
    ------
    AccelcalError
        For a window shorter than 16 samples or longer than half the
        recording, no plateau at all, or a plateau shorter than
        ``min_periods`` periods after the trimming.
    """
    w = round(window_s * rate)
    if w < 16 or 2 * w > x.size:
        raise AccelcalError(f"{where}: a detection window of {window_s:g} s is {w} samples of "
                            f"{x.size}; give a window from 16 samples to half the recording",
                            parameter="step_window")
    hop = w // 2
    lines = []
    for a in range(0, x.size - w + 1, hop):
        f, share = spectral_peak(x[a:a + w], rate)
        lines.append(f if share >= 0.5 else None)
    bin_hz = rate / w
    groups, current = [], None
    for i, f in enumerate(lines):
        if f is not None and current is not None and abs(f - current[1]) <= bin_hz:
            current[2] = i
            continue
        if current is not None:
            groups.append(current)
        current = [i, f, i] if f is not None else None
    if current is not None:
        groups.append(current)
    out = []
    for first, f, last in groups:
        a, b = first * hop + w, last * hop
        if b <= a:  # no longer than the two trimmed windows: a change of frequency
            continue
        periods = int(np.floor(max(b - a, 0) * f / rate))
        if periods < min_periods:
            raise AccelcalError(
                f"{where}: the step at {f:.4g} Hz from {first * hop / rate:.6g} s holds "
                f"{periods} whole periods once a window is trimmed at each end, fewer than "
                f"{min_periods}: record longer steps or give a shorter step window",
                parameter="min_periods")
        out.append((a, b, None))
    if not out:
        raise AccelcalError(f"{where}: no step of constant frequency found (no window's line "
                            "holds half its power)")
    return out


def check_step(ref, dut, line, rate: float, f: float | None, *, min_periods: int,
               where: str) -> dict:
    """A step's frequency (given or detected), periods and coherence, after its checks.

    Returns
    -------
    dict
        ``frequency_hz``, ``periods``, ``coherence``.

    Raises
    ------
    AccelcalError
        For a step clipped, of fewer than ``min_periods`` whole periods, or
        whose frequency is not in the reference channel (module docs).
    """
    from accelcal.signal.clipping import MIN_RUN, clipped
    from accelcal.signal.sinefit import sine_fit3, sine_fit4

    if ref.size < 16:
        raise AccelcalError(f"{where}: {ref.size} samples are too few for a step",
                            parameter="min_periods")
    if f is None:
        start, share = spectral_peak(line, rate)
        try:
            f = float(sine_fit4(line, rate, start).frequency) if share >= 0.5 else None
        except AccelcalError:
            f = None
        if f is None or not 0 < f < rate / 2:
            raise AccelcalError(f"{where}: no frequency found in the data (no line holds half "
                                "the channel's power): give the step's frequency",
                                parameter="frequencies")
        f = nominal(f)
    if not 0 < f < rate / 2:
        raise AccelcalError(f"{where}: {f:g} Hz is not below the Nyquist frequency "
                            f"{rate / 2:g} Hz", parameter="frequencies")
    periods = int(np.floor(ref.size * f / rate + 1e-9))
    if periods < min_periods:
        raise AccelcalError(f"{where} ({f:.6g} Hz): {ref.size} samples at {rate:g} Hz hold "
                            f"{periods} whole periods, fewer than {min_periods}",
                            parameter="min_periods")
    run = max(MIN_RUN, int(np.ceil(CLIP_PERIOD_FRACTION * rate / f)))
    for name, x in (("ref", ref), ("dut", dut)):
        clip = clipped(x, min_run=run)
        if clip.runs:
            start, stop, rail = clip.runs[0]
            raise AccelcalError(f"{where} ({f:.6g} Hz): the {name} channel is clipped at "
                                f"{rail:.6g} ({stop - start} samples from "
                                f"{start / rate:.6g} s in the step): lower the amplitude or "
                                "widen the channel's range")
    m = round(periods * rate / f)
    explained = {name: _explained(x[:m], rate, f, sine_fit3) for name, x in
                 (("ref", ref), ("dut", dut))}
    if explained["ref"] < MIN_EXPLAINED:
        raise AccelcalError(f"{where}: {f:.6g} Hz is not in the data (a sine at it explains "
                            f"{100 * explained['ref']:.3g} % of the ref channel's variance, "
                            f"less than {100 * MIN_EXPLAINED:g} %)", parameter="frequencies")
    return {"frequency_hz": f, "periods": periods, "coherence": explained["dut"]}


def nominal(f: float) -> float:
    """``f`` snapped to its nominal value where within :data:`NOMINAL_PPM` of it."""
    digits = NOMINAL_DIGITS - 1 - int(np.floor(np.log10(f)))
    near = float(round(f, digits))
    return near if abs(near - f) <= NOMINAL_PPM * 1e-6 * f else f


def _explained(x, rate, f, fit) -> float:
    """Fraction of the variance of ``x`` that the sine at ``f`` explains."""
    var = float(np.var(x))
    if var == 0.0:
        return 0.0
    amp = abs(complex(np.ravel(fit(x, rate, f).phasors)[0]))
    return min(amp**2 / 2 / var, 1.0)


def _covers(reference: dict, freqs) -> None:
    table = reference.get("frequency_hz") or []
    lo, hi = (min(table), max(table)) if table else (np.nan, np.nan)
    out = [f for f in freqs if not lo * (1 - 1e-12) <= f <= hi * (1 + 1e-12)]
    if out:
        raise AccelcalError(f"the reference table covers {lo:g}-{hi:g} Hz, not the step at "
                            f"{out[0]:.6g} Hz: give a reference certificate that covers the band",
                            parameter="reference")


def _write(out: Path, record) -> None:
    """Write ``record``, read it back with the kind's reader, then move it into place."""
    from accelcal.io.atomic import atomic_path
    from accelcal.io.formats import response as fmt

    with tempfile.TemporaryDirectory(dir=out.parent, prefix=".accelcal-import-") as stage:
        staged = Path(stage) / out.name
        fmt.write(staged, record)
        try:
            fmt.read(staged)
        except AccelcalError as exc:
            raise AccelcalError(f"the response record would not be valid: "
                                f"{str(exc).replace(str(staged), str(out))}") from None
        with atomic_path(out) as tmp:
            os.replace(staged, tmp)
