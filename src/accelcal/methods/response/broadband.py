"""Comparison with broadband excitation (random or swept sine): H1 from Welch cross-spectra.

The reference ``x`` and the DUT ``y``, sampled together over one long
record, give Welch's averaged spectra (:mod:`accelcal.signal.spectra`,
accumulated block by block: a record of any length streams in bounded
memory), and at each frequency bin in the excited band::

    S_dut(f) = S_ref(f) H1(f) / D(f),    H1 = G_xy / G_xx,

``S_ref`` the reference's certificate, ``D`` the DAQ's known channel
mismatch. The coherence ``gamma^2 = |G_xy|^2 / (G_xx G_yy)`` gives the
normalized random error of ``|H1|`` and the standard deviation of its
phase (rad) for ``n_d`` averages [BP2010]_::

    e_r = sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d)),

so each point's ``[Re, Im]`` covariance is ``(e_r |S|)^2 I`` (magnitude and
phase errors equal and uncorrelated: a circle), with ``2 n_d`` degrees of
freedom. Neighbouring bins share the window's spectral kernel: the errors
of H1 at bins ``m`` apart correlate as ``|rho_m|^2``, ``rho_m`` the
correlation of the windowed DFT of white noise at lag ``m`` (for Hann
``4/9`` and ``1/36`` at lags 1 and 2), which the covariance states, so that
a model fitted to the bins is not given more independent points than it has.
Bins below a coherence limit are flagged and left out (the rest
go on); none left is an error. H1 is unbiased by noise on the DUT's
channel; noise on the reference's biases it low by ``G_nn / G_xx``, which
the coherence does not show.

References
----------
.. [BP2010] Bendat J. S., Piersol A. G., Random Data, 4th ed., 2010,
   sec. 9.2 (H1, coherence, random errors, eq. 9.90 and 9.52).
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


def _blocks_of(record):
    for start in range(0, record.ref.size, BLOCK):
        yield record.ref[start:start + BLOCK], record.dut[start:start + BLOCK]


def stream_file(path):
    """The metadata of a response record file and its ``(ref, dut)`` blocks, streamed.

    Returns
    -------
    meta : dict
        The record's metadata (``sample_rate_hz``, ``output_unit`` and the rest).
    blocks : iterator of (numpy.ndarray, numpy.ndarray)
    """
    from accelcal.io.formats.response import KIND, check_header, check_metadata
    from accelcal.io.recordings import InputOptions, iter_blocks
    from accelcal.io.recordings.sources import open_source

    meta = open_source(path, "record", None).metadata
    if meta.get("kind") != KIND:
        raise AccelcalError(f"{path}: kind is {meta.get('kind')!r}, expected {KIND!r}")
    check_header(meta.get("sample_rate_hz"), meta.get("output_unit"), path)
    check_metadata(meta, path, 1)
    opts = InputOptions(input_format="record", columns=("ref", "dut"),
                        rate=float(meta["sample_rate_hz"]))
    blocks = iter_blocks(path, opts, channels=2, what="response record")
    return meta, ((b.values[:, 0], b.values[:, 1]) for b in blocks)


def reduce_broadband(source, reference=None, *, segment: int | None = None,
                     min_coherence: float = MIN_COHERENCE, band=None,
                     reference_frequency: float | None = None):
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

    Returns
    -------
    accelcal.results.Reduction
        Method ``response/broadband``: one complex coefficient per bin kept,
        circular ``[Re, Im]`` covariances, ``dof`` ``2 n_d``; observations
        also ``coherence``, ``flagged_hz`` (the bins left out).

    Raises
    ------
    AccelcalError
        For a record that is not broadband, too short for one segment, a
        reference that does not cover the band, no bin of enough coherence.
    """
    from os import PathLike

    from accelcal.rigs.shaker_response import ReferenceTable
    from accelcal.signal.spectra import CrossSpectra

    if isinstance(source, str | PathLike):
        meta, blocks = stream_file(source)
        fs, unit, samples = float(meta["sample_rate_hz"]), meta["output_unit"], None
    else:
        meta, blocks = source.metadata, _blocks_of(source)
        fs, unit, samples = source.sample_rate_hz, source.output_unit, source.ref.size
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
    for x, y in blocks:
        spectra.add(x, y)
    sp = spectra.result()
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
    values = s_ref * sp.h1[keep] / (gain * np.exp(-2j * np.pi * f * delay))
    sd = sp.random_error()[keep] * np.abs(values)
    blocks_cov = [np.eye(2) * s * s for s in sd]
    bins = np.flatnonzero(keep)
    dof = int(np.floor(2 * sp.n_d))
    points = {"freqs": f, "amps": np.full(f.size, excitation.get("level_g", np.nan), float),
              "values": values, "blocks": blocks_cov, "dofs": [dof] * f.size,
              "periods": np.full(f.size, sp.segments)}
    red = assemble(
        METHOD, f"{unit}/g", points, reference_frequency,
        extra=(
            Assumption("segment", int(nperseg), "samples",
                       f"Welch segments of {nperseg} samples ({fs / nperseg:.4g} Hz bins), "
                       f"Hann window, 3/4 overlap: {sp.segments} averages, "
                       f"{sp.n_d:.1f} independent"),
            Assumption("min_coherence", float(min_coherence), "",
                       f"{flagged.size} bin(s) below it left out"),
            Assumption("daq", (gain, delay), "", "DUT channel's gain ratio and delay (s) "
                       "relative to the reference's, corrected")),
        note=("Comparison with broadband excitation: H1 = G_xy / G_xx from Welch "
              "cross-spectra times the reference's sensitivity; random error of magnitude "
              "and phase from the coherence and the averages (Bendat and Piersol)."),
        provenance={"segments": int(sp.segments), "samples": int(spectra.samples)})
    from dataclasses import replace

    est = replace(red.estimate, covariance=_correlated(sd, bins, spectra.window))
    return replace(red, sensors=(est,),
                   observations={**red.observations, "coherence": coherence[keep],
                                 "flagged_hz": flagged})


def bin_correlation(window: np.ndarray, lags: int = 3) -> np.ndarray:
    """``|rho_m|^2`` for ``m = 0 .. lags``: the correlation of H1's errors at bins ``m`` apart.

    ``rho_m = sum w^2 exp(-2 pi i m n / N) / sum w^2``, the correlation of the
    windowed DFT of white noise at bins ``m`` apart (both channels' errors
    pass the same kernel, hence the square).
    """
    n = window.size
    w2 = window**2
    rho = [np.sum(w2 * np.exp(-2j * np.pi * m * np.arange(n) / n)) / np.sum(w2)
           for m in range(lags + 1)]
    return np.abs(np.asarray(rho)) ** 2


def _correlated(sd: np.ndarray, bins: np.ndarray, window: np.ndarray) -> np.ndarray:
    """The points' ``[Re, Im]`` covariance with the neighbouring bins' correlation."""
    corr = bin_correlation(window)
    m = sd.size
    cov = np.zeros((2 * m, 2 * m))
    lag = np.abs(bins[:, None] - bins[None, :])
    rho = np.where(lag < corr.size, corr[np.minimum(lag, corr.size - 1)], 0.0)
    cov_pts = rho * np.outer(sd, sd)
    cov[0::2, 0::2] = cov_pts
    cov[1::2, 1::2] = cov_pts
    return cov
