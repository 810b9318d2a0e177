"""Deviations and the IEEE 952 fit of long still recordings, in bounded memory.

A 24 h record at 1 kHz has 8.6e7 samples (690 MB as float64). It is read
block by block (:func:`accelcal.io.recordings.iter_blocks`, Arrow batches);
each block extends the phase ``x = cumsum(y - c)`` in a temporary file
(``numpy.memmap``, float64, in ``tmpdir`` or ``TMPDIR``, its name removed as soon
as it is open, so nothing is left however the run ends);
``c`` is the mean of the first :data:`CHUNK` samples, and the cumulative
sum runs over fixed chunks of :data:`CHUNK` samples at absolute positions,
so the phase, and every result, is bit-for-bit the same whatever the block
size (and the same as :func:`deviation_of_samples` in memory). Then the
kernels of :mod:`~accelcal.signal.allan.kernels` read the memmap in
chunks, and the PSD is accumulated from the phase's differences
(:class:`~accelcal.methods.noise.psd.WelchAccumulator`).

Resident memory: O(block rows) for the block being read (``rows`` x 8
bytes x a few), O(:data:`~accelcal.signal.allan.kernels.CHUNK`) for
the kernels, ``64 x MAX_SEGMENT`` samples for the PSD and at most
:data:`~accelcal.signal.allan.identify.ID_AVERAGES` phase points for the noise
identification at short taus (as in memory):
171 MiB measured for 1e8 samples (libraries included), whatever the length, plus the
page cache the kernel lends to the memmap (reclaimable; not the process's).
Disk: 8 bytes per sample in the temporary file.

Kinds streamed: ``oadev`` and ``ohdev`` (lagged differences of the phase);
``adev``, ``hdev``, ``mdev`` and ``totdev`` need the record in memory
(:func:`accelcal.signal.allan.deviations.deviation`).

A time column is checked for gaps (an interval longer than 1.5 sample
intervals): a gap is refused, never averaged over, unless the options say
``gaps="split"`` (the deviation pooled within segments,
:mod:`~accelcal.methods.noise.gapped`) or ``"fill"``; so is a sample beyond
:data:`accelcal.io.formats.noise.MAX_VALUE` (a corrupt cell).

References
----------
.. [Riley2008] Riley W. J., NIST SP 1065, 2008, eqs. (11), (20) (the
   overlapping kernels on the phase).
"""

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np

from accelcal.errors import AccelcalError

CHUNK = 1 << 16
"""Samples per cumulative-sum chunk (fixed positions: results independent of the block size)."""

STREAM_KINDS = ("oadev", "ohdev")
"""Deviations computed from the phase on disk."""


class _Phase:
    """Builds ``x = cumsum(y - c)`` chunk by chunk (fixed chunks) into a sink."""

    def __init__(self, write):
        self.write = write
        self.pending = []
        self.size = 0
        self.centre = None
        self.last = 0.0
        self.samples = 0

    def add(self, y: np.ndarray) -> None:
        self.pending.append(y)
        self.size += y.size
        if self.size >= CHUNK:
            self._flush(final=False)

    def _flush(self, final: bool) -> None:
        data = np.concatenate(self.pending) if self.pending else np.empty(0)
        whole = data.size if final else (data.size // CHUNK) * CHUNK
        for a in range(0, whole, CHUNK):
            chunk = data[a:a + CHUNK]
            if self.centre is None:
                self.centre = float(np.mean(chunk))
                self.write(np.zeros(1))
            x = np.cumsum(chunk - self.centre)
            x += self.last
            self.last = float(x[-1])
            self.write(x)
            self.samples += chunk.size
        self.pending = [data[whole:]]
        self.size = data.size - whole

    def finish(self) -> None:
        self._flush(final=True)


def phase_of(y) -> np.ndarray:
    """The phase :func:`stream_deviation` writes, computed in memory (same bits)."""
    parts = []
    builder = _Phase(parts.append)
    builder.add(np.asarray(y, dtype=float).reshape(-1))
    builder.finish()
    return np.concatenate(parts)


def _deviation_from_phase(x, rate, kind, taus, confidence, unit, progress=None,  # noqa: PLR0917
                          segments=None, force=False):
    from accelcal.signal.allan.deviations import DIVISOR, Deviation
    from accelcal.signal.allan.edf import check_confidence, confidence_interval, edf
    from accelcal.signal.allan.identify import interval_alphas
    from accelcal.signal.allan.kernels import lag_sumsq
    from accelcal.signal.allan.taus import check_work, tau_grid, taus_to_m

    if kind not in STREAM_KINDS:
        raise AccelcalError(f"{kind} needs the record in memory; stream {' or '.join(STREAM_KINDS)}"
                            " (or read a shorter record whole)", parameter="kind")
    confidence = check_confidence(confidence)
    n = len(x) - 1
    spec = taus if isinstance(taus, str) else taus_to_m(taus, rate)
    order = 2 if kind == "oadev" else 3
    if segments is not None and len(segments) > 1:  # over gaps: pooled within segments
        from accelcal.methods.noise.gapped import pooled_sums

        n = max(b - a for a, b in segments)  # the grid and the EDF of the longest segment
        m = tau_grid(n, spec, kind=kind)
        check_work(len(x) - 1, m, kind, force=force)
        sums, counts = pooled_sums(x, m, segments, order)
        m, sums, counts = m[counts > 0], sums[counts > 0], counts[counts > 0]
    else:
        m = tau_grid(n, spec, kind=kind)
        check_work(n, m, kind, force=force)
        counts = (n + 1 - order * m).astype(np.int64)
        sums = np.empty(m.size)
        for k, mk in enumerate(int(v) for v in m):
            sums[k] = lag_sumsq(x, 0, int(counts[k]), mk, order)  # Eqs. (11), (20) [Riley2008]
            if progress:
                progress(k + 1, m.size)
    dev = np.sqrt(sums / (DIVISOR[kind] * counts)) / m
    if not np.all(dev > 0):
        raise AccelcalError("the signal is constant; a deviation of 0 says nothing",
                            parameter="values")
    # noise identification: taus with more than ID_AVERAGES averages use the record's start;
    # the long taus carry the alpha of the longest identified ones (as in memory)
    alphas, sources = interval_alphas(x, m, kind)
    dof = edf(kind, alphas, m, n)
    lo, hi = confidence_interval(dev, dof, confidence)
    return Deviation(kind=kind, tau=m / rate, m=m, n=counts, dev=dev, alpha=alphas, edf=dof,
                     lo=lo, hi=hi, confidence=confidence, unit=str(unit), rate=float(rate),
                     samples=len(x) - 1, alpha_source=sources)


def _psd_from_phase(x, rate):
    from accelcal.methods.noise.psd import WelchAccumulator, segment_length

    acc = WelchAccumulator(rate, segment_length(len(x) - 1))
    step = 16 * CHUNK
    for a in range(0, len(x) - 1, step):
        acc.add(np.diff(np.asarray(x[a:a + step + 1])))
    return acc.result()


def deviation_of_samples(y, rate, *, kind="oadev", taus="octave", confidence=0.683, unit=""):
    """In memory, what :func:`stream_deviation` computes from a file (for checks)."""
    return _deviation_from_phase(phase_of(y), float(rate), kind, taus, confidence, unit)


def stream_deviation(path, options=None, *, kind="oadev", taus="octave", confidence=0.683,
                     rows=None, tmpdir=None, progress=None, psd=False, force=False,
                     repairs=None):
    """Deviation of a one-channel recording file, streamed (bounded memory).

    Parameters
    ----------
    path : path-like
        CSV, Parquet or record file (:mod:`accelcal.io.recordings`).
    options : accelcal.io.recordings.InputOptions, optional
        How to read it (one column).
    kind : {"oadev", "ohdev"}
    taus, confidence
        As :func:`accelcal.signal.allan.deviations.deviation`.
    rows : int, optional
        Rows per block read.
    tmpdir : path-like, optional
        Directory of the temporary phase file (default ``TMPDIR``).
    progress : callable, optional
        ``progress(done, total)``: rows read (total None when unknown), then taus.
    psd : bool
        Also return the Welch PSD.
    force : bool
        Run a tau set estimated to take longer than
        :data:`~accelcal.signal.allan.taus.MAX_SECONDS` (refused otherwise).
    repairs : accelcal.io.recordings.repairs.Repairs, optional
        Collects what was found in the time column and done about it; with
        ``options.gaps == "split"`` the deviation is pooled over the segments
        (:mod:`~accelcal.methods.noise.gapped`).

    Returns
    -------
    deviation : accelcal.signal.allan.deviations.Deviation
    spectrum : (numpy.ndarray, numpy.ndarray) or None
    provenance : dict
        The file (name, SHA-256, columns, unit, rate, samples).

    Raises
    ------
    AccelcalError
        One line: unreadable file, NaN or empty cell, time going backwards
        or with a gap, no rate, constant signal, too short for the taus.
    """
    from accelcal.io.formats.noise import check_values
    from accelcal.io.recordings import InputOptions, describe, iter_blocks
    from accelcal.io.recordings.read import DEFAULT_BLOCK_ROWS
    from accelcal.io.recordings.repairs import Repairs

    options = options or InputOptions(input_format="record")
    repairs = Repairs() if repairs is None else repairs
    split = options.gaps == "split"
    prov, rate = describe(path, options, channels=1, what="still recording")
    with _phase_file(tmpdir) as fh:
        builder = _Phase(lambda a: fh.write(np.ascontiguousarray(a).tobytes()))
        last_time = None
        for block in iter_blocks(path, options, rows=rows or DEFAULT_BLOCK_ROWS,
                                 channels=1, what="still recording", repairs=repairs):
            if not split:
                last_time = _check_gaps(block, rate, last_time, prov["file"])
            check_values(block.values, block.start, prov["file"])
            builder.add(block.values[:, 0])
            if progress:
                progress(block.start + block.values.shape[0], None)
        builder.finish()
        fh.flush()
        if builder.samples < 4:
            raise AccelcalError(f"{prov['file']}: {builder.samples} samples are too few for a "
                                "deviation (at least 4)", parameter="values")
        x = np.memmap(fh, dtype=np.float64, mode="r", shape=(builder.samples + 1,))
        unit = options.unit or prov.get("unit", "")
        dev = _deviation_from_phase(x, rate, kind, taus, confidence, unit, progress,
                                    repairs.segments if split else None, force)
        # a spectrum needs consecutive samples: none over split gaps
        spectrum = _psd_from_phase(x, rate) if psd and len(repairs.segments) < 2 else None
        del x
    mean = builder.centre + builder.last / builder.samples  # x[n] = sum(y - c)
    extra = {"repairs": repairs.to_dict()} if repairs else {}
    return dev, spectrum, {**prov, "samples": builder.samples, "mean": mean, **extra}


@contextlib.contextmanager
def _phase_file(tmpdir):
    """An open binary file for the phase, in ``tmpdir`` (or the temp directory), already unlinked.

    The name is removed as soon as the file is open: the open file (and
    the memory map made of it) keeps the data, and the space returns to the
    disk when the file is closed, however the run ends (even SIGKILL).
    Older phase files of processes that are gone are removed first
    (:func:`accelcal.io.atomic.sweep`). A failed write (a full disk, a
    file-size limit) is one line naming the directory.
    """
    from accelcal.io.atomic import sweep, temp_name, write_error

    directory = Path(tmpdir if tmpdir is not None else tempfile.gettempdir())
    path = directory / temp_name("accelcal-phase", ".f64", directory=directory)
    try:
        sweep(directory)
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
        os.unlink(path)
    except OSError as exc:
        raise write_error(path, exc) from None
    try:
        with os.fdopen(fd, "w+b") as fh:
            yield fh
    except OSError as exc:
        raise write_error(path, exc) from None


def _check_gaps(block, rate, last, file):
    """Refuse an interval longer than 1.5 sample intervals (a gap); return the last time."""
    if block.time is None or block.time.size == 0:
        return last
    t = block.time if last is None else np.concatenate(([last], block.time))
    big = np.flatnonzero(np.diff(t) > 1.5 / rate)
    if big.size:
        row = block.start + int(big[0]) + (0 if last is None else -1) + 2
        raise AccelcalError(
            f"{file}: a gap of {np.diff(t)[big[0]]:.6g} s before data row {row} (the sample "
            f"interval is {1 / rate:.6g} s); deviations need evenly spaced samples: split the "
            "record at the gap", parameter="values")
    return float(block.time[-1])


def stream_fit(path, options=None, *, terms=None, taus="octave", confidence=0.683, rows=None,
               tmpdir=None, progress=None, force=False):
    """The IEEE 952 fit (:func:`~accelcal.methods.noise.fit.fit_deviation`) of a file, streamed.

    Returns
    -------
    accelcal.results.Reduction
        With the PSD and the file's provenance.
    """
    from accelcal.methods.noise.fit import TERMS, fit_deviation

    dev, spectrum, prov = stream_deviation(path, options, kind="oadev", taus=taus,
                                           confidence=confidence, rows=rows, tmpdir=tmpdir,
                                           progress=progress, psd=True, force=force)
    return fit_deviation(dev, terms=terms or TERMS, provenance={"input": prov},
                         spectrum=spectrum, mean=prov["mean"])
