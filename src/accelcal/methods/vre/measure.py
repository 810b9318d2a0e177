"""Vibrafuge records reduced to measured VRE: whole-period means.

A :class:`~accelcal.io.formats.vibrafuge.VibrafugeRun` (simulated by
:mod:`accelcal.rigs.vibrafuge` or read by
:func:`~accelcal.io.formats.vibrafuge.read_vibrafuge`) holds a static and a
vibrating record per test point. The VRE of a point is
``(mean_vibrating - mean_static) / scale_factor``, both means over whole
periods of the vibration (the record need not start at phase zero; the
partial period at the end is left out), with standard
uncertainty ``sqrt(u_v^2 + u_s^2) / |scale_factor|`` from each record's
residual noise after removing the periodic signal by synchronous averaging
(all harmonics, which the asymmetry term has), or after removing harmonics
0..8 when the span holds fewer than two repeats of the sampled phases
(:func:`accelcal.signal.periods.whole_period_mean`).

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   sec. 2 (VRE as the difference of whole-period means).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.io.formats.vibrafuge import VibrafugeRun
from accelcal.results import Assumption
from accelcal.signal.periods import whole_period_mean

HARMONICS = 8
"""Harmonics of the vibration removed before estimating the noise level when
the synchronous estimate is not available. The asymmetry term has harmonics
of every order; leaving some in makes the uncertainty conservative, never
biases the mean."""


@dataclass(frozen=True)
class VreMeasurement:
    """VRE of each test point of a run, with standard uncertainty.

    Attributes
    ----------
    overload : numpy.ndarray, shape (P, 3)
        Overload vectors, g.
    amplitude : numpy.ndarray, shape (P,)
        Vibration amplitudes, g.
    direction : numpy.ndarray, shape (3,)
        Vibration direction.
    vre : numpy.ndarray, shape (P,)
        Measured VRE, g.
    uncertainty : numpy.ndarray, shape (P,)
        Standard uncertainty of the VRE from the records' noise, g.
    static_mean, vibrating_mean : numpy.ndarray, shape (P,)
        Whole-period means, output unit.
    periods, samples, discarded : int
        Whole periods and samples used, samples left out at the end.
    scale_factor : float
        Nominal scale factor (output unit per g) that expressed the VRE in g.
    output_unit : str
        Unit of the records.
    sampling : str
        Sampling model of the records (``"integrating"``, ``"point"``,
        ``"measured"``).
    """

    overload: np.ndarray
    amplitude: np.ndarray
    direction: np.ndarray
    vre: np.ndarray
    uncertainty: np.ndarray
    static_mean: np.ndarray
    vibrating_mean: np.ndarray
    periods: int
    samples: int
    discarded: int
    scale_factor: float = 1.0
    output_unit: str = "g"
    sampling: str = "measured"

    def rows(self) -> list[dict]:
        """One dict per point (for tables and CSV/JSON output)."""
        return [
            {"point": k, "overload_g": float(b[0]), "overload_oa_g": float(b[1]),
             "overload_pa_g": float(b[2]), "amplitude_g": float(a), "vre_g": float(v),
             "u_vre_g": float(u)}
            for k, (b, a, v, u) in enumerate(
                zip(self.overload, self.amplitude, self.vre, self.uncertainty, strict=True))
        ]

    def assumptions(self) -> tuple[Assumption, ...]:
        """What the VRE values assume, for :func:`~accelcal.methods.vre.identify`.

        Names: ``vre`` (how a VRE is formed from the records), ``sampling``
        (the records' sampling model) and ``scale_factor`` (the nominal scale
        factor, output unit per g, that expresses the VRE in g).
        """
        return (
            Assumption("vre", "whole-period means",
                       text=("the VRE of each point is the whole-period mean vibrating minus "
                             "static, divided by the nominal scale factor")),
            Assumption("sampling", self.sampling, text=f"records sampled: {self.sampling}"),
            Assumption("scale_factor", float(self.scale_factor), f"{self.output_unit}/g",
                       text=(f"nominal scale factor {self.scale_factor:.6g} "
                             f"{self.output_unit}/g")),
        )


def reduce_run(run: VibrafugeRun, *, harmonics: int = HARMONICS) -> VreMeasurement:
    """Reduce static and vibrating records to VRE with standard uncertainty.

    Parameters
    ----------
    run : VibrafugeRun
        Records of one or more points (simulated or read from a file).
    harmonics : int
        Harmonics of the vibration frequency removed before estimating the
        noise (affects the uncertainty only).

    Returns
    -------
    VreMeasurement

    Raises
    ------
    AccelcalError
        For records shorter than one period, or without a whole-period span.

    References
    ----------
    .. [1] Guan2021, sec. 2: VRE = whole-period mean vibrating minus static.
    """
    fs, f = run.sample_rate, run.frequency
    vib = whole_period_mean(run.vibrating, fs, f, harmonics=harmonics, what="vibrating record")
    sta = whole_period_mean(run.static, fs, f, harmonics=harmonics, what="static record")
    k1 = run.scale_factor
    vre = (np.atleast_1d(vib.mean) - np.atleast_1d(sta.mean)) / k1  # Eq. (9)/(21) [Guan2021]
    u = np.hypot(np.atleast_1d(vib.std), np.atleast_1d(sta.std)) / abs(k1)
    return VreMeasurement(
        overload=run.overload, amplitude=run.amplitude, direction=run.direction, vre=vre,
        uncertainty=u, static_mean=np.atleast_1d(sta.mean), vibrating_mean=np.atleast_1d(vib.mean),
        periods=vib.periods, samples=vib.samples, discarded=vib.discarded,
        scale_factor=k1, output_unit=run.output_unit, sampling=run.sampling,
    )
