"""Noise and stability of still recordings: Allan deviations, IEEE 952 coefficients.

The package:

:mod:`~accelcal.signal.allan.deviations` (with ``dev_kernels``, ``taus``, ``edf``, ``identify``)
    ADEV, overlapping ADEV, MDEV, HDEV, overlapping HDEV, TOTDEV with noise
    identification, EDF and confidence intervals (NIST SP 1065).
:mod:`~accelcal.methods.noise.fit`
    :func:`fit`, :func:`fit_deviation`: the IEEE 952 coefficients Q, N, B,
    K, R by weighted non-negative least squares on the Allan variance, with
    uncertainties (family ``"noise"``, method ``"noise/ieee952-fit"``);
    :func:`coefficients`, :func:`navigation_units`.
:mod:`~accelcal.methods.noise.covariance`
    :func:`avar_covariance`: the covariance of Allan variances across taus.
:mod:`~accelcal.methods.noise.psd`
    :func:`welch_psd`, :class:`WelchAccumulator`, :func:`levels`.
:mod:`~accelcal.methods.noise.stream`
    :func:`stream_deviation`, :func:`stream_fit`: long records in bounded memory.
:mod:`~accelcal.methods.noise.stability`
    :func:`run_to_run`: turn-on to turn-on repeatability beside in-run stability.
:mod:`~accelcal.methods.noise.export`
    :func:`noise_yaml`: N and K as Kalibr's imu.yaml (``noise fit --export``).
:mod:`~accelcal.methods.noise.figures`
    :func:`figures`: deviation plot with bars and fitted terms, PSD plot.

Record files of kind ``noise`` are :mod:`accelcal.io.formats.noise`; the
simulator is :mod:`accelcal.rigs.noise`. The verbs every method package
has: :func:`simulate` (the rig) and :func:`reduce` (a recording, streamed
from its file, or a record to the IEEE 952 fit: what ``accelcal noise fit``
does); :func:`fit` (samples) stays as it was.

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C.
.. [IEEE1293] IEEE Std 1293-2018, annex.
.. [Riley2008] Riley W. J., Handbook of Frequency Stability Analysis, NIST SP
   1065, 2008.
.. [ElSheimy2008] El-Sheimy N., Hou H., Niu X., Analysis and modeling of
   inertial sensors using Allan variance, IEEE Trans. Instrum. Meas. 57(1), 2008.
"""

from accelcal.methods import ReportText
from accelcal.methods.noise.figures import figures
from accelcal.methods.noise.fit import (
    FAMILY,
    METHOD,
    TERMS,
    coefficients,
    fit,
    fit_deviation,
    model_avar,
    navigation_units,
)

__all__ = ["ERRATA", "FAMILY", "METHOD", "TERMS", "coefficients", "figures", "fit",
           "fit_deviation", "model_avar", "navigation_units", "reduce", "report_text",
           "simulate"]

ERRATA = ()
"""No corrections of the references are shown."""


def report_text(reduction) -> ReportText:
    """Title and summary of a noise fit's report section."""
    from accelcal.methods.noise.fit import coefficients as coefs

    prov = reduction.provenance
    hours = prov.get("samples", 0) / prov.get("rate_hz", 1.0) / 3600.0
    nav = coefs(reduction)["navigation"]
    parts = [f"{t} = {rows[0]['value']:.3g} ± {rows[0]['std']:.2g} {rows[0]['unit']}"
             for t, rows in nav.items()]
    stability = reduction.assumed("run_to_run")
    extra = (f" Turn-on to turn-on bias repeatability {stability:.3g} {prov.get('unit', '')} "
             "(SD of the run means) beside the in-run stability B." if stability else "")
    fits = reduction.assumed("model_fits", True)
    gof = reduction.assumed("goodness_of_fit")
    bound = reduction.assumed("at_bound", ())
    if gof is not None:
        extra += (f" Goodness of fit chi^2 = {gof[0]:.3g} on {gof[1]} dof (Birge ratio "
                  f"{reduction.assumed('birge_ratio'):.3g}): "
                  + ("the noise model describes the record." if fits else
                     "the noise model does NOT describe the record; the uncertainties are "
                     "multiplied by the Birge ratio, and the figure shows where the fitted "
                     "curve leaves the measured intervals."))
    if bound:
        extra += f" At the bound 0 (not resolved by the data): {', '.join(bound)}."
    return ReportText(
        title="noise and stability (still recording)",
        summary=(f"Still recording of {hours:.3g} h at {prov.get('rate_hz', 0):g} Hz; "
                 "overlapping Allan deviation at octave taus with EDF-based intervals; IEEE 952 "
                 "coefficients by weighted non-negative least squares on the Allan variance "
                 "(uncertainties from the covariance of the Allan variances across taus). "
                 + ("; ".join(parts) + "." if parts else "") + extra),
        sensor_summary="IEEE 952 noise terms fitted to the overlapping Allan variance.",
    )


def simulate(*, seed=0, **settings):
    """A simulated still recording: the rig's :func:`accelcal.rigs.noise.simulate`.

    ``settings``: the IEEE 952 coefficients ``N``, ``B``, ``K``, ``Q``, ``R``,
    ``rate``, ``duration``, ``bias``, ``unit``, ``b_range``, ``channel``;
    ``seed`` an int, SeedSequence or Generator.
    """
    from accelcal.rigs.noise import simulate as rig_simulate

    return rig_simulate(seed=seed, **settings)


def reduce(records, *, options=None, terms=None, taus="octave", confidence: float = 0.683,
           progress=None, force: bool = False):
    """The IEEE 952 fit of a still recording, as ``accelcal noise fit`` does [IEEE952]_.

    Parameters
    ----------
    records : path-like or accelcal.io.formats.noise.NoiseRecord
        A file (CSV, Parquet or noise record), streamed in bounded memory
        (:func:`accelcal.methods.noise.stream.stream_fit`), or a record in
        memory (its first channel, :func:`fit`).
    options : accelcal.io.recordings.InputOptions, optional
        How to read the file.
    terms : sequence of str, optional
        Terms to fit (default :data:`TERMS`).
    taus : str or sequence
        Tau set.
    confidence : float
        Level of the deviation's intervals.
    progress : callable, optional
        Called with the rows read (a file only).
    force : bool
        Run a tau set estimated to take longer than
        :data:`~accelcal.signal.allan.taus.MAX_SECONDS` (a file only; refused otherwise).

    Returns
    -------
    accelcal.results.Reduction
        Method ``noise/ieee952-fit``.
    """
    from os import PathLike

    if isinstance(records, str | PathLike):
        from accelcal.methods.noise.stream import stream_fit

        return stream_fit(records, options, terms=terms, taus=taus, confidence=confidence,
                          progress=progress, force=force)
    return fit(records.values[:, 0], records.rate, terms=terms or TERMS, taus=taus,
               confidence=confidence, unit=records.unit)


def from_inputs(files, record):
    """Candidate reductions of a record's input files (:mod:`accelcal.methods`)."""
    from accelcal.io.lab_metadata import read_metadata
    from accelcal.method_ids import route_of
    from accelcal.methods.noise.fit import POWERS
    from accelcal.methods.noise.stream import stream_fit

    if route_of(record.method) != "ieee952-fit":
        return []
    red = stream_fit(files[0], terms=tuple(n for n in record.names if n in POWERS))
    true = read_metadata(files[0]).get("true")
    truth = {k: v for k, v in true.items() if k in POWERS} if isinstance(true, dict) else None
    return [(red, {"truth": truth})]
