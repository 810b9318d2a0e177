"""How long to record: periods (stepped sine) or averages (broadband) for a stated uncertainty.

Stepped sine: the three-parameter fit of ``n`` samples on whole periods of a
sine of amplitude ``A`` in white noise ``sigma`` gives a phasor whose real and
imaginary parts have the standard deviation ``sigma sqrt(2 / n)``
[IEEE1057]_, so its relative magnitude error and its phase error (rad) are
both ``sigma sqrt(2 / n) / A = 1 / (snr sqrt(n))``, ``snr = (A / sqrt 2) /
sigma`` the channel's RMS signal-to-noise ratio. The ratio of the DUT's
phasor to the reference's adds the two channels' in quadrature::

    u_rel = u_phase = sqrt(1 / snr_ref^2 + 1 / snr_dut^2) / sqrt(n),

hence the samples ``n`` and the whole periods ``n f / fs`` a target needs.

Broadband: with the DUT's noise alone, the coherence in a bin is
``gamma^2 = snr^2 / (1 + snr^2)`` (``snr`` the ratio of the DUT's signal to
its noise, RMS, in the bin), so the random error
``sqrt(1 - gamma^2) / (|gamma| sqrt(2 (n_d - 1)))`` is ``1 / (snr sqrt(2 (n_d - 1)))``
[BP2010]_ (one average spent on the window's leakage input, as the reduction
does: :meth:`accelcal.signal.spectra.Spectra.conditioned`); the averages
``n_d`` give the Welch segments at the reduction's
overlap (:func:`accelcal.signal.spectra.equivalent_averages`) and the record's
length at a bin width.

References
----------
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.3 (three-parameter sine fit).
.. [BP2010] Bendat J. S., Piersol A. G., Random Data, 4th ed., 2010, eq. 9.52
   and 9.90.
"""

import numpy as np

from accelcal.errors import AccelcalError

ROUTES = ("stepped", "broadband")
"""The routes :func:`plan` plans."""

MAX_SAMPLES = 1e12
"""Most samples a plan may ask for (beyond it the target is out of reach)."""

MAX_FREQUENCIES = 1000
"""Most step frequencies planned at once."""

MAX_SEGMENT = 1 << 24
"""Longest Welch segment planned, samples."""


def _samples(n: float) -> float:
    if not n <= MAX_SAMPLES:
        raise AccelcalError(f"the target needs {n:.3g} samples, more than {MAX_SAMPLES:g}: "
                            "a larger uncertainty or a better SNR", parameter="magnitude_u_pct")
    return n


def _check(name, value, lo, hi, unit) -> float:
    if not (isinstance(value, int | float) and lo < value <= hi):
        raise AccelcalError(f"must be above {lo:g} and up to {hi:g} {unit}, got {value!r}",
                            parameter=name)
    return float(value)


def plan(*, route: str = "stepped", snr_db: float = 40.0, ref_snr_db: float | None = None,
         magnitude_u_pct: float = 0.1, phase_u_deg: float = 0.1, frequencies=(80.0,),
         sample_rate: float = 10000.0, resolution_hz: float = 5.0) -> list[dict]:
    """What a frequency-response test needs for a stated standard uncertainty.

    Parameters
    ----------
    route : str
        ``stepped`` or ``broadband``.
    snr_db : float
        The DUT channel's RMS signal-to-noise ratio, dB (broadband: in a bin).
    ref_snr_db : float, optional
        The reference channel's (stepped; default the DUT's).
    magnitude_u_pct, phase_u_deg : float
        Target standard uncertainties of the magnitude (%) and phase (deg).
    frequencies : sequence of float
        Step frequencies, Hz (stepped).
    sample_rate : float
        Hz.
    resolution_hz : float
        Bin width, Hz (broadband).

    Returns
    -------
    list of dict
        Stepped: per frequency ``frequency_hz, samples, periods, record_s``
        and the uncertainties then reached, ``magnitude_u_pct, phase_u_deg``.
        Broadband: one row ``segment, averages, n_d, record_s`` and the same.

    Raises
    ------
    AccelcalError
        For a route not in :data:`ROUTES`, out-of-range settings.
    """
    if route not in ROUTES:
        raise AccelcalError(f"{route!r} is not one of {', '.join(ROUTES)}", parameter="route")
    snr = 10 ** (_check("snr_db", snr_db, -40.0, 200.0, "dB") / 20)
    u_mag = _check("magnitude_u_pct", magnitude_u_pct, 1e-9, 50.0, "%") / 100
    u_ph = np.deg2rad(_check("phase_u_deg", phase_u_deg, 1e-9, 30.0, "deg"))
    fs = _check("sample_rate", sample_rate, 0.0, 1e8, "Hz")
    resolution_hz = _check("resolution_hz", resolution_hz, fs / MAX_SEGMENT, fs / 16, "Hz")
    target = min(u_mag, u_ph)
    if route == "broadband":
        from accelcal.methods.response.broadband import OVERLAP
        from accelcal.signal.spectra import equivalent_averages

        nperseg = max(16, round(fs / resolution_hz))
        n_d = 1.0 + 1.0 / (2.0 * snr**2 * target**2)
        _samples(n_d * nperseg / 4)
        step = nperseg - int(np.floor(OVERLAP * nperseg))
        from scipy.signal import get_window

        window = get_window("hann", nperseg)
        ratio = 64 / equivalent_averages(64, window, step)
        segments = max(1, int(np.ceil(n_d * ratio)))
        n_d = equivalent_averages(segments, window, step)
        while (n_d - 1.0) * 2 * snr**2 * target**2 < 1:
            segments += 1
            n_d = equivalent_averages(segments, window, step)
        reached = 1.0 / (snr * np.sqrt(2 * (n_d - 1.0)))
        samples = (segments - 1) * step + nperseg
        return [{"route": route, "frequency_hz": float(fs / nperseg), "segment": nperseg,
                 "averages": segments, "n_d": float(n_d), "samples": int(samples),
                 "record_s": float(samples / fs), "magnitude_u_pct": 100 * reached,
                 "phase_u_deg": float(np.rad2deg(reached))}]
    ref = snr if ref_snr_db is None else 10 ** (_check("ref_snr_db", ref_snr_db, -40.0,
                                                       200.0, "dB") / 20)
    k2 = 1.0 / ref**2 + 1.0 / snr**2
    if not 1 <= len(frequencies) <= MAX_FREQUENCIES:
        raise AccelcalError(f"give 1 to {MAX_FREQUENCIES} frequencies",
                            parameter="frequencies")
    rows = []
    for given in frequencies:
        f = _check("frequencies", given, 0.0, fs / 6, "Hz")
        per_period = fs / f
        _samples(k2 / target**2)
        periods = max(3, int(np.ceil(k2 / target**2 / per_period)))
        samples = round(periods * per_period)
        reached = float(np.sqrt(k2 / samples))
        rows.append({"route": route, "frequency_hz": f, "segment": 0, "averages": periods,
                     "n_d": float(periods), "samples": int(samples),
                     "record_s": float(periods / f), "magnitude_u_pct": 100 * reached,
                     "phase_u_deg": float(np.rad2deg(reached))})
    return rows
