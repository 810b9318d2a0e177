"""Comparison with broadband excitation (random or swept sine): H1 from Welch cross-spectra.

The reference ``x`` and the DUT ``y``, sampled together over one long
record, give Welch's averaged spectra (:mod:`accelcal.signal.spectra`,
accumulated block by block: a record of any length streams in bounded
memory), and at each frequency bin in the excited band::

    S_dut(f) = S_ref(f) H(f) / D(f),

``S_ref`` the reference's certificate, ``D`` the DAQ's known channel
mismatch and ``H`` the H1 estimate ``G_xy.z / G_xx.z`` of the spectra
conditioned on the window's leakage input ``z`` (``x`` under the window's
derivative; :meth:`accelcal.signal.spectra.Spectra.conditioned`). The plain
``H1 = G_xy / G_xx`` carries, beside the output noise, the leakage of the
DUT's impulse response across the segment's edges [AS2009]_: a random error
that the coherence counts but that falls mostly on the phase at 3/4 overlap,
so that the magnitude's error was stated about 25 % too large below 500 Hz
at the default settings and fits to the bins came out conservative. With
``z`` fitted out,
the partial coherence ``gamma^2`` of ``x`` and ``y`` gives the normalized
random error of ``|H|`` and the standard deviation of its phase (rad) for
``n_d`` averages, one spent on ``z`` [BP2010]_::

    e_r = sqrt(1 - gamma^2) / (|gamma| sqrt(2 (n_d - 1))),

the output noise's alone, circular, so each point's ``[Re, Im]`` covariance
is ``(e_r |S|)^2 I`` (magnitude and phase errors equal and uncorrelated),
with ``2 (n_d - 1)`` degrees of freedom. Neighbouring bins share the
window's spectral kernel: the errors of H at bins ``m`` apart correlate as
the squared correlation of the windowed DFTs of white noise at lag ``m``,
summed over the overlapped segments' pairs (:func:`bin_correlation`; Hann at
3/4 overlap 0.490 and 0.048 at lags 1 and 2, without overlap 4/9 and 1/36),
which the covariance states, so that a model fitted to the bins is not given more
independent points than it has. Bins below a coherence limit (the ordinary
coherence) are flagged and left out (the rest go on); none left is an
error. H is unbiased by noise on the DUT's channel; noise on the
reference's biases it low by ``G_nn / G_xx``, which the coherence does not
show.

A gap in the record's time column (a step over 1.5 sample intervals,
:mod:`accelcal.io.record_gaps`) is refused by default; with ``gaps="split"``
no segment spans it: the averages are taken over the pieces between gaps and
pooled (:meth:`accelcal.signal.spectra.CrossSpectra.restart`, ``n_d`` the sum
of the pieces'; the bins' correlation is taken as for one piece of as many
segments, slightly on the high side), a piece shorter than one segment left
out and counted. A gap is never filled: interpolated samples of a random or
swept excitation are not the DUT's response to it, and bias H1.

References
----------
.. [BP2010] Bendat J. S., Piersol A. G., Random Data, 4th ed., 2010,
   sec. 7.2 (conditioned spectra), 9.2 (H1, coherence, random errors, eq. 9.90
   and 9.52) and 9.3 (multiple-input random errors).
.. [AS2009] Antoni J., Schoukens J., IEEE Trans. Instrum. Meas. 58(9), 2009,
   p. 3276-3287 (leakage errors of overlapped segment averaging).
.. [ISO16063-21] ISO 16063-21:2003 (comparison; broadband excitation).
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.response.stepped import _daq, assemble
from accelcal.results import Assumption

METHOD = "response/broadband"
"""Method id of the comparison with broadband excitation."""

MIN_COHERENCE = 0.9
"""Default lowest coherence of a bin kept."""

OVERLAP = 0.75
"""Overlap of the Welch segments: at three quarters the squared Hann windows sum to a
constant, so that a sweep's energy is weighed alike wherever it falls in a segment (at
one half, a system's group delay would bias H1 of a sweep by about delay / segment)."""

MIN_AVERAGES = 2.0
"""Fewest equivalent independent averages (Hann at 3/4 overlap: 4 segments): one goes to the
window's leakage input, and the random error needs one more."""

MAX_SEGMENT = 1 << 24
"""Longest Welch segment, samples."""

BLOCK = 1 << 18
"""Samples per block fed to the spectra (a record in memory is fed in these too)."""


def default_segment(fs: float, band, samples: int | None) -> int:
    """Samples per segment: the power of two whose bins are no wider than the band's low edge.

    At most an eighth of the record (so that about 30 segments average).
    """
    n = 1 << int(np.ceil(np.log2(max(16.0, fs / band[0]))))
    if samples is not None:
        while n > 16 and n > samples / 8:
            n //= 2
    return n


GAPS_FILL = ("--gaps fill does not apply: interpolated samples of a random or swept "
             "excitation are not the DUT's response to it, and bias H1")
"""Why a broadband record's gaps are never filled."""


def _blocks_of(record):
    for start in range(0, record.ref.size, BLOCK):
        stop = start + BLOCK
        yield start, record.t[start:stop], record.ref[start:stop], record.dut[start:stop]


def stream_file(path, gaps: str = "refuse", repairs=None):
    """The metadata of a response record file and its ``(start, t, ref, dut)`` blocks, streamed.

    ``gaps`` and ``repairs``: as :func:`accelcal.io.recordings.iter_blocks`
    (with ``split``, rows with a missing cell are dropped and counted; the
    gaps themselves are found by :func:`reduce_broadband`).

    Returns
    -------
    meta : dict
        The record's metadata (``sample_rate_hz``, ``output_unit`` and the rest).
    blocks : iterator of (int, numpy.ndarray, numpy.ndarray, numpy.ndarray)
        The first data row's index (0-based), the time column (s) and the channels.
    """
    from accelcal.io.formats.response import KIND, check_header, check_metadata
    from accelcal.io.recordings import InputOptions, iter_blocks
    from accelcal.io.recordings.sources import open_source

    meta = open_source(path, "record", None).metadata
    if meta.get("kind") != KIND:
        raise AccelcalError(f"{path}: kind is {meta.get('kind')!r}, expected {KIND!r}")
    check_header(meta.get("sample_rate_hz"), meta.get("output_unit"), path)
    check_metadata(meta, path, 1)
    opts = InputOptions(input_format="record", columns=("ref", "dut"), time="t",
                        gaps="split" if gaps == "split" else "refuse")
    blocks = iter_blocks(path, opts, channels=2, what="response record", repairs=repairs)
    return meta, ((b.start, b.time, b.values[:, 0], b.values[:, 1]) for b in blocks)


class _Pieces:
    """The record's gaps found block by block: refused, or the spectra restarted at each.

    A step of the time column over :data:`~accelcal.io.record_gaps.GAP_FACTOR`
    sample intervals is a gap (:mod:`accelcal.io.record_gaps`).
    """

    def __init__(self, spectra, fs: float, gaps: str, name: str):
        self.spectra, self.interval, self.gaps, self.name = spectra, 1.0 / fs, gaps, name
        self.last = None
        self.gap_rows, self.short_rows, self.bounds = [], [], [0]
        self.short_samples = 0
        self.piece_row = 1  # data row of the current piece's first sample

    def add(self, start: int, t, x, y) -> None:
        from accelcal.io.record_gaps import GAP_FACTOR

        full = t if self.last is None else np.r_[self.last, t]
        steps = np.diff(full)
        head = 1 if self.last is None else 0  # the block's sample after step k is k + head
        at = np.flatnonzero(steps > GAP_FACTOR * self.interval) + head
        if at.size and self.gaps != "split":
            k = int(at[0])
            step = float(steps[k - head])
            raise AccelcalError(
                f"{self.name}: time column 't' jumps {step:.6g} s (about "
                f"{round(step / self.interval) - 1} samples missing) at data row "
                f"{start + k + 1}; Welch segments need consecutive samples: give --gaps split "
                "(the averages taken over the pieces between gaps and pooled, a piece "
                f"shorter than one segment left out); {GAPS_FILL}")
        prev = 0
        for k in at:
            self.spectra.add(x[prev:k], y[prev:k])
            if self.spectra.restart() == 0:
                self.short_rows.append(self.piece_row)
                self.short_samples += start + int(k) + 1 - self.piece_row
            self.piece_row = start + int(k) + 1
            self.gap_rows.append(self.piece_row)
            self.bounds.append(start + int(k))
            prev = int(k)
        self.spectra.add(x[prev:], y[prev:])
        if t.size:
            self.last = t[-1]

    def found(self, total: int, io: dict | None) -> dict | None:
        """What was found and done, as ``Repairs.to_dict()`` (None when nothing was).

        ``total``: the samples read; ``io``: the reader's own findings (or None).
        Closes the last piece (left out too when shorter than a segment).
        """
        from accelcal.io.record_gaps import finding

        if self.gap_rows and self.spectra.restart() == 0:
            self.short_rows.append(self.piece_row)
            self.short_samples += total + 1 - self.piece_row

        listed = [f for f in (io or {}).get("found", []) if f["found"] != "gaps"]
        if self.gap_rows:
            listed.append(finding("gaps in the time column", "split: Welch averages over "
                                  "the pieces between gaps, pooled", self.gap_rows))
        if self.short_rows:
            listed.append(finding("pieces shorter than one Welch segment",
                                  f"left out ({self.short_samples} samples)",
                                  self.short_rows))
        if not listed:
            return None
        out = {"found": listed}
        if self.gap_rows:
            out["segments"] = [[a, b] for a, b in zip(self.bounds, [*self.bounds[1:], total],
                                                       strict=True)]
        return out


def reduce_broadband(source, reference=None, *, segment: int | None = None,
                     min_coherence: float = MIN_COHERENCE, band=None,
                     reference_frequency: float | None = None, gaps: str = "refuse"):
    """The DUT's complex sensitivity at each bin of a broadband record.

    Parameters
    ----------
    source : ResponseRecord or path-like
        A record whose ``excitation`` is ``random`` or ``swept``, or its file
        (streamed in blocks: bounded memory).
    reference : accelcal.rigs.shaker_response.ReferenceTable, optional
        The reference's certificate; default the record's own.
    segment : int, optional
        Samples per Welch segment (Hann window, :data:`OVERLAP`); default
        :func:`default_segment`.
    min_coherence : float
        Bins of lower coherence are flagged and left out.
    band : (float, float), optional
        Frequencies kept, Hz; default the record's excited band.
    reference_frequency : float, optional
        Frequency of the deviations, Hz.
    gaps : {"refuse", "split"}
        A gap in the time column (a step over 1.5 sample intervals): refused
        with the row, or with ``split`` the Welch averages are taken over the
        pieces between gaps and pooled (a piece shorter than one segment is
        left out and counted); never filled (:data:`GAPS_FILL`). What was
        found is in the provenance (``repairs``) and notes.

    Returns
    -------
    accelcal.results.Reduction
        Method ``response/broadband``: one complex coefficient per bin kept,
        circular ``[Re, Im]`` covariances, ``dof`` ``2 (n_d - 1)``; observations
        also ``coherence``, ``flagged_hz`` (the bins left out).

    Raises
    ------
    AccelcalError
        For a record that is not broadband, too short for :data:`MIN_AVERAGES`
        averages, a reference that does not cover the band, no bin of enough
        coherence.
    """
    from os import PathLike

    from accelcal.io.record_gaps import check_gap_options
    from accelcal.io.recordings.repairs import Repairs, with_repairs
    from accelcal.rigs.shaker_response import ReferenceTable
    from accelcal.signal.spectra import CrossSpectra

    check_gap_options(gaps, 5)
    if gaps == "fill":
        raise AccelcalError(f"{GAPS_FILL}; give --gaps split")
    io = Repairs()
    if isinstance(source, str | PathLike):
        meta, blocks = stream_file(source, gaps, io)
        fs, unit, samples = float(meta["sample_rate_hz"]), meta["output_unit"], None
        name = str(source)
    else:
        meta, blocks = source.metadata, _blocks_of(source)
        fs, unit, samples = source.sample_rate_hz, source.output_unit, source.ref.size
        name = "the record"
    excitation = meta.get("excitation") or {}
    if excitation.get("kind") not in ("random", "swept"):
        raise AccelcalError(f"a broadband reduction needs a random or swept record, not a "
                            f"{excitation.get('kind', 'stepped')} one", parameter="method")
    if band is None:
        band = excitation.get("band_hz")
    try:
        lo, hi = (float(x) for x in band)
    except (TypeError, ValueError):
        raise AccelcalError("give the band as two frequencies lo,hi (Hz)",
                            parameter="band") from None
    if not 0 < lo < hi:
        raise AccelcalError(f"the band {lo:g},{hi:g} must have 0 < lo < hi", parameter="band")
    if not 0 <= min_coherence < 1:
        raise AccelcalError(f"must be in [0, 1), got {min_coherence!r}",
                            parameter="min_coherence")
    if reference is None:
        if "reference" not in meta:
            raise AccelcalError("the record states no reference certificate: give one "
                                "(a CSV table)", parameter="reference")
        reference = ReferenceTable.from_dict(meta["reference"])
    gain, delay = _daq(meta)
    nperseg = default_segment(fs, (lo, hi), samples) if segment is None else segment
    if not (isinstance(nperseg, int) and 16 <= nperseg <= MAX_SEGMENT):
        raise AccelcalError(f"must be a whole number of samples from 16 to {MAX_SEGMENT}, "
                            f"got {segment!r}", parameter="segment")
    spectra = CrossSpectra(fs, nperseg, overlap=OVERLAP)
    pieces = _Pieces(spectra, fs, gaps, name)
    for start, t, x, y in blocks:
        pieces.add(start, t, x, y)
    found = pieces.found(spectra.samples, io.to_dict() if io else None)
    sp = spectra.result()
    if sp.n_d < MIN_AVERAGES:
        raise AccelcalError(f"{sp.segments} Welch segment(s) of {nperseg} samples hold "
                            f"{sp.n_d:.2g} independent averages, fewer than {MIN_AVERAGES:g} "
                            "(one is spent on the window's leakage): a longer record or "
                            "shorter segments", parameter="segment")
    cond = sp.conditioned()
    inside = (sp.frequency >= lo) & (sp.frequency <= hi) & (sp.frequency > 0)
    if not inside.any():
        raise AccelcalError(f"no bin of {fs / nperseg:g} Hz falls in {lo:g}-{hi:g} Hz: "
                            "longer segments", parameter="segment")
    coherence = sp.coherence
    keep = inside & (coherence >= min_coherence)
    flagged = sp.frequency[inside & ~keep]
    if not keep.any():
        raise AccelcalError(f"no bin in {lo:g}-{hi:g} Hz reaches the coherence limit "
                            f"{min_coherence:g} (highest {coherence[inside].max():.3g})",
                            parameter="min_coherence")
    f = sp.frequency[keep]
    s_ref = reference.sensitivity(f)
    values = s_ref * cond.h1[keep] / (gain * np.exp(-2j * np.pi * f * delay))
    sd = cond.random_error()[keep] * np.abs(values)
    blocks_cov = [np.eye(2) * s * s for s in sd]
    bins = np.flatnonzero(keep)
    dof = int(np.floor(2 * cond.n_d))
    points = {"freqs": f, "amps": np.full(f.size, excitation.get("level_g", np.nan), float),
              "values": values, "blocks": blocks_cov, "dofs": [dof] * f.size,
              "periods": np.full(f.size, sp.segments)}
    red = assemble(
        METHOD, f"{unit}/g", points, reference_frequency,
        extra=(
            Assumption("segment", int(nperseg), "samples",
                       f"Welch segments of {nperseg} samples ({fs / nperseg:.4g} Hz bins), "
                       f"Hann window, 3/4 overlap: {sp.segments} averages, "
                       f"{sp.n_d:.1f} independent, one spent on the window's leakage"),
            Assumption("min_coherence", float(min_coherence), "",
                       f"{flagged.size} bin(s) below it left out"),
            Assumption("daq", (gain, delay), "", "DUT channel's gain ratio and delay (s) "
                       "relative to the reference's, corrected")),
        note=("Comparison with broadband excitation: H1 from Welch cross-spectra "
              "conditioned on the window's leakage input, times the reference's "
              "sensitivity; random error of magnitude and phase from the partial "
              "coherence and the averages (Bendat and Piersol)."),
        provenance={"segments": int(sp.segments), "samples": int(spectra.samples)})
    from dataclasses import replace

    est = replace(red.estimate, covariance=_correlated(sd, bins, spectra))
    return with_repairs(replace(
        red, sensors=(est,),
        observations={**red.observations, "coherence": coherence[keep], "flagged_hz": flagged,
                      "kernel": bin_kernel(spectra.window), "bin_hz": fs / nperseg}), found)


def bin_kernel(window: np.ndarray, lags: int = 3) -> np.ndarray:
    """The weights ``k_m``, ``m = -lags .. lags``, of H1's average of the response over bins.

    ``|W_m|^2 / sum |W_m|^2``, ``W_m`` the window's DFT at whole bins (for
    Hann ``1/6, 2/3, 1/6``): H1 of white excitation expects
    ``sum_m k_m H(f + m df)``, the response seen through the window's squared
    spectrum, whose second moment (1/3 of a bin squared for Hann) is that of
    the continuous kernel, hence the curvature's bias ``H'' df^2 / 6`` [BP2010]_.
    Weights below 1e-12 are dropped (the kernel's length is then odd and
    centred).
    """
    spec = np.abs(np.fft.fft(window)) ** 2
    k = np.concatenate([spec[-lags:], spec[:lags + 1]]) / np.sum(spec)
    keep = np.flatnonzero(k > 1e-12)
    half = int(max(np.max(np.abs(keep - lags)), 0)) if keep.size else 0
    return k[lags - half:lags + half + 1] / np.sum(k[lags - half:lags + half + 1])


def bin_correlation(window: np.ndarray, step: int, segments: int, lags: int = 3) -> np.ndarray:
    """The correlation of H's errors at bins ``m`` apart, ``m = 0 .. lags``.

    Both channels' noise passes the same kernel, so the error of H1 at bin
    ``m`` from a pair of segments ``j`` steps apart weighs as
    ``|R_m(j)|^2``, ``R_m(j) = sum_n w[n] w[n + j step] exp(-2 pi i m n / N) /
    sum w^2`` the correlation of the windowed DFTs of white noise at bins ``m``
    apart and segments ``j`` apart; summed over the pairs as Welch's
    equivalent averages [Welch1967]_::

        c_m = sum_j (1 - |j| / K) |R_m(j)|^2 / sum_j (1 - |j| / K) |R_0(j)|^2.

    Without overlap ``c_m = |R_m(0)|^2`` (Hann: 4/9, 1/36); Hann at 3/4
    overlap gives 0.490 and 0.048 (the overlapped pairs add to the
    neighbours' correlation).

    References
    ----------
    .. [Welch1967] Welch P. D., IEEE Trans. Audio Electroacoust. 15(2), 1967,
       p. 70-73.
    """
    n = window.size
    phase = np.exp(-2j * np.pi * np.arange(n) / n)
    sums = np.zeros(lags + 1)
    reach = min(segments - 1, (n - 1) // step)  # pairs farther apart do not overlap
    for j in range(-reach, reach + 1):
        shift = abs(j) * step
        prod = window[:n - shift] * window[shift:]
        r = np.array([np.sum(prod * phase[:n - shift] ** m) for m in range(lags + 1)])
        sums += (1.0 - abs(j) / segments) * np.abs(r) ** 2
    return sums / sums[0]


def _correlated(sd: np.ndarray, bins: np.ndarray, spectra) -> np.ndarray:
    """The points' ``[Re, Im]`` covariance with the neighbouring bins' correlation."""
    corr = bin_correlation(spectra.window, spectra.step, spectra.segments)
    m = sd.size
    cov = np.zeros((2 * m, 2 * m))
    lag = np.abs(bins[:, None] - bins[None, :])
    rho = np.where(lag < corr.size, corr[np.minimum(lag, corr.size - 1)], 0.0)
    cov_pts = rho * np.outer(sd, sd)
    cov[0::2, 0::2] = cov_pts
    cov[1::2, 1::2] = cov_pts
    return cov
