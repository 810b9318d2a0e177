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

Point-sampled records (``sampling == "point"``) average the output over the
sampled phases only: the sign term of the asymmetry changes between samples,
so their whole-period mean differs from the continuous mean of the closed
forms by up to ``|K0'| / q + pi |K1'| A_i / (2 q)`` g for ``q`` distinct
phases (2.7e-8 g in K0' for the default model and settings, larger than the
noise of a 1 s record). The phases are known (frequency, sample rate and the
record's ``phase``), so :meth:`VreMeasurement.design_columns` evaluates every
term's VRE exactly as the records sample it (:func:`sampled_columns`) and
:func:`~accelcal.methods.vre.identify` fits with those columns: no
discretisation error is left to include in the uncertainty.

References
----------
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021,
   sec. 2 (VRE as the difference of whole-period means).
.. [IEEE1057] IEEE Std 1057-2017, sec. 4.1.
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.vibrafuge import VibrafugeRun, read_vibrafuge
from accelcal.methods.vre.closed_form import vre_columns
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
    phases : numpy.ndarray or None
        For point-sampled records, the vibration phase of every sample of
        the whole-period span, rad (shape ``(samples,)``); None otherwise.
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
    phases: np.ndarray | None = None

    def design_columns(self) -> dict[str, np.ndarray]:
        """VRE per unit coefficient of every term at each point, as these records measure it.

        The closed forms (:func:`~accelcal.methods.vre.vre_columns`: the
        continuous whole-period mean, which integrating sampling delivers
        exactly), or for point-sampled records the means over the sampled
        phases (:func:`sampled_columns`). Pass them to
        :func:`~accelcal.methods.vre.identify` as ``columns``.
        """
        if self.phases is None:
            return vre_columns(self.overload, self.amplitude, self.direction)
        return sampled_columns(self.overload, self.amplitude, self.direction, self.phases)

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
            Assumption("sampling", self.sampling, text=(
                f"records sampled: {self.sampling}" + (
                    "; each term's VRE evaluated at the sampled phases (no discretisation "
                    "error)" if self.phases is not None else ""))),
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
    bad = np.flatnonzero(~(np.isfinite(vre) & np.isfinite(u)))
    if bad.size:
        raise AccelcalError(
            f"point {int(bad[0])}: the VRE or its uncertainty is not finite (beyond the float "
            "range): the records' values or the scale factor are not those of an accelerometer"
        )
    phases = None
    if run.sampling == "point":
        phases = 2.0 * np.pi * f * (np.arange(vib.samples) / fs) + run.phase
    return VreMeasurement(
        overload=run.overload, amplitude=run.amplitude, direction=run.direction, vre=vre,
        uncertainty=u, static_mean=np.atleast_1d(sta.mean), vibrating_mean=np.atleast_1d(vib.mean),
        periods=vib.periods, samples=vib.samples, discarded=vib.discarded,
        scale_factor=k1, output_unit=run.output_unit, sampling=run.sampling, phases=phases,
    )


def sampled_columns(overload, amplitude, direction, phases) -> dict[str, np.ndarray]:
    """VRE per unit coefficient of every term, averaged over the sampled phases.

    Parameters
    ----------
    overload : numpy.ndarray, shape (P, 3)
        Overload vectors in IA, OA, PA, g.
    amplitude : numpy.ndarray, shape (P,)
        Vibration amplitudes, g.
    direction : numpy.ndarray, shape (3,)
        Unit vibration direction.
    phases : numpy.ndarray, shape (M,)
        Vibration phase of each sample of the whole-period span, rad.

    Returns
    -------
    dict of str to numpy.ndarray, shape (P,)
        For each name of :data:`~accelcal.methods.vre.VRE_TERMS`: the mean of
        the term's input function over the samples minus its value at rest,
        with ``a_j = A u_j sin(theta_n) + b_j`` (for the asymmetry terms
        ``1/2 (mean sgn a_i - sgn b_i)`` and ``1/2 (mean |a_i| - |b_i|)``).
        Exact for point-sampled records; equal to the closed forms
        (:func:`~accelcal.methods.vre.vre_columns`) as the phases become dense.

    References
    ----------
    .. [1] Guan2021, eqs. (3), (4), (8), (21) (the terms averaged), evaluated
       at the sample instants instead of over the continuous period.
    """
    b = np.asarray(overload, dtype=float)
    s = np.sin(np.asarray(phases, dtype=float))
    a = (np.asarray(amplitude, dtype=float)[:, None] * direction)[:, :, None] * s + b[:, :, None]
    ai, ao, ap = a[:, 0], a[:, 1], a[:, 2]
    bi, bo, bp = b[:, 0], b[:, 1], b[:, 2]

    def vre(values, at_rest):  # Eq. (8) [Guan2021]: mean while vibrating minus at rest
        return values.mean(axis=-1) - at_rest

    return {
        "K2": vre(ai**2, bi**2), "K3": vre(ai**3, bi**3), "K4": vre(ai**4, bi**4),
        "Koo": vre(ao**2, bo**2), "Kpp": vre(ap**2, bp**2), "Kio": vre(ai * ao, bi * bo),
        "Kip": vre(ai * ap, bi * bp), "Kop": vre(ao * ap, bo * bp),
        "K0_asym": 0.5 * vre(np.sign(ai), np.sign(bi)),  # Eq. (3) [Guan2021]
        "K1_asym": 0.5 * vre(np.abs(ai), np.abs(bi)),  # Eq. (3) [Guan2021]
    }


def measure_runs(runs) -> dict:
    """The measured VRE of several vibrafuge runs (or their files), points concatenated.

    Each run is reduced by :func:`reduce_run`; a path is read by
    :func:`accelcal.io.formats.vibrafuge.read_vibrafuge`.

    Returns
    -------
    dict
        ``overload`` (P, 3), ``amplitude``, ``vre``, ``uncertainty`` (P,),
        ``direction`` (P, 3), ``columns`` (term -> design column, the
        runs' :meth:`VreMeasurement.design_columns`) and ``assumptions``.

    Raises
    ------
    AccelcalError
        For no run, or a file that cannot be read.
    """
    from os import PathLike

    runs = list(runs)
    if not runs:
        raise AccelcalError("give at least one vibrafuge record file", parameter="records")
    parts = [reduce_run(read_vibrafuge(r) if isinstance(r, str | PathLike) else r) for r in runs]
    cat = {k: np.concatenate([getattr(p, k) for p in parts])
           for k in ("overload", "amplitude", "vre", "uncertainty")}
    cat["direction"] = np.concatenate(
        [np.broadcast_to(p.direction, (p.amplitude.size, 3)) for p in parts])
    designs = [p.design_columns() for p in parts]
    cat["columns"] = {t: np.concatenate([d[t] for d in designs]) for t in designs[0]}
    cat["assumptions"] = [a for p in parts for a in p.assumptions()]
    return cat
