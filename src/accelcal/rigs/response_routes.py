"""The frequency response's other routes: broadband excitation, a laser interferometer, gravity.

Beside the stepped-sine comparison of :mod:`accelcal.rigs.shaker_response`:

:class:`BroadbandRig`
    The shaker driven by band-limited random noise or by a logarithmic
    sine sweep, reference and DUT sampled together over one long record
    (ISO 16063-21 with broadband excitation). Both channels are made in the
    frequency domain: the acceleration's spectrum times each sensor's
    complex sensitivity (and the DAQ's mismatch), back by an inverse FFT,
    so the record is the exact steady-state (circular) response to a
    repeated excitation. The sweep reaches :data:`SWEEP_MARGIN` beyond the
    band on either side (below the Nyquist frequency's 0.45), so that the
    band's edges are swept through, not reached at the record's ends.
:class:`LaserRig`
    Primary calibration, ISO 16063-11 method 3: the shaker's motion seen by a
    homodyne (double-pass Michelson) interferometer whose quadrature signals
    carry the ellipse errors of [Heydemann1981]_::

        I = a cos(phi) + p,   Q = b sin(phi + e) + q,   phi = 4 pi s / lambda + phi0,

    ``s`` the displacement, stepped sine as in the comparison; the record's
    ``ref`` is ``I`` and its ``quadrature`` column ``Q``.
:class:`GravityRig`
    ISO 16063-16: the DUT rotated at a constant rate about a horizontal axis
    (its sensitive axis in the plane of rotation), so that gravity gives it
    the input ``g cos(theta)``, ``theta = 2 pi f t + theta0``, 1 g at the
    rotation frequency; with its bias and second-order coefficient. The
    record's ``ref`` is the table's encoder angle, rad.

Each writes a :class:`~accelcal.io.formats.response.ResponseRecord` whose
``excitation`` metadata names the route and its settings and whose ``true``
metadata is the DUT's transfer function.

References
----------
.. [ISO16063-11] ISO 16063-11:1999, Primary vibration calibration by laser
   interferometry, method 3 (sine approximation).
.. [ISO16063-16] ISO 16063-16:2014, Calibration by Earth's gravitation.
.. [Heydemann1981] Heydemann P. L. M., "Determination and correction of
   quadrature fringe measurement errors in interferometers", Appl. Opt.
   20(19), 1981, p. 3382-3384.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.response import ResponseRecord
from accelcal.resources import generator
from accelcal.rigs.shaker_response import (
    MAX_SAMPLES,
    DutResponse,
    ReferenceTable,
    default_reference,
)

G_N = 9.80665
"""Standard gravity, m/s^2 per g."""

SWEEP_MARGIN = 1.25
"""Factor by which a sweep starts below and ends above the band."""

HE_NE = 632.8e-9
"""Wavelength of a helium-neon laser, m."""


def _check_daq(gain_ratio, delay_s, noise) -> None:
    if not (0 < gain_ratio <= 1e6 and abs(delay_s) <= 1.0):
        raise AccelcalError("the DAQ's gain ratio must be in (0, 1e6] and its delay within "
                            "1 s", parameter="gain_ratio")
    if not 0 <= noise <= 1e6:
        raise AccelcalError("must be >= 0 (V rms)", parameter="noise")


def _record(cols, fs, unit, meta, seed) -> ResponseRecord:
    if isinstance(seed, int):
        meta["seed"] = seed
    return ResponseRecord(**cols, sample_rate_hz=float(fs), output_unit=unit, metadata=meta)


@dataclass(frozen=True)
class BroadbandRig:
    """Random or swept-sine excitation of reference and DUT back to back.

    Attributes
    ----------
    kind : str
        ``random`` (Gaussian noise, flat in the band) or ``swept`` (a
        logarithmic sweep across the band over the record).
    band_hz : tuple of float
        Lowest and highest frequency excited, Hz.
    level_g : float
        RMS acceleration (random) or the sweep's amplitude, g.
    duration_s : float
        Record length, s.
    sample_rate : float
        Rate of both channels, Hz.
    reference : ReferenceTable
        The reference's certificate (its true sensitivity here; beyond the
        table, its first and last entries).
    gain_ratio, delay_s : float
        The DUT channel's gain and delay relative to the reference's.
    noise : float
        White noise of the DUT's channel, V rms.
    ref_noise : float
        White noise of the reference's channel, V rms: it biases H1 low by
        the noise-to-signal ratio of the reference's spectrum (not shown by
        the coherence's random error).
    """

    kind: str = "random"
    band_hz: tuple = (5.0, 2000.0)
    level_g: float = 1.0
    duration_s: float = 20.0
    sample_rate: float = 10000.0
    reference: ReferenceTable = field(default_factory=default_reference)
    gain_ratio: float = 1.0
    delay_s: float = 0.0
    noise: float = 1e-4
    ref_noise: float = 1e-5

    def __post_init__(self) -> None:
        if self.kind not in ("random", "swept"):
            raise AccelcalError(f"must be random or swept, got {self.kind!r}",
                                parameter="excitation")
        if not 1.0 <= self.sample_rate <= 1e7:
            raise AccelcalError(f"must be from 1 Hz to 1e7 Hz, got {self.sample_rate!r}",
                                parameter="sample_rate")
        lo, hi = (*tuple(self.band_hz), 0.0, 0.0)[:2]
        if len(self.band_hz) != 2 or not 0 < lo < hi < self.sample_rate / 2:
            raise AccelcalError(f"give two frequencies lo,hi with 0 < lo < hi below the "
                                f"Nyquist frequency {self.sample_rate / 2:g} Hz",
                                parameter="band")
        if not 0 < self.level_g <= 1e4:
            raise AccelcalError("must be above 0 and up to 1e4 g", parameter="level")
        n = self.duration_s * self.sample_rate
        if not 16 <= n <= MAX_SAMPLES:
            raise AccelcalError(f"the record would hold {n:.3g} samples per channel: give "
                                f"16 to {MAX_SAMPLES:g}", parameter="duration")
        work.simulated("response", f"a {self.kind} record of {self.duration_s:g} s at "
                       f"{self.sample_rate:g} Hz", n, parameter="duration",
                       hint="give a shorter duration or a lower rate")
        _check_daq(self.gain_ratio, self.delay_s, self.noise)
        _check_daq(1.0, 0.0, self.ref_noise)

    def sweep(self) -> tuple[float, float]:
        """First and last frequency of the sweep, Hz."""
        lo, hi = self.band_hz
        return lo / SWEEP_MARGIN, min(hi * SWEEP_MARGIN, 0.45 * self.sample_rate)

    def acceleration(self, rng) -> np.ndarray:
        """The shaker's acceleration, g, one sample per sample time."""
        n = round(self.duration_s * self.sample_rate)
        lo, hi = self.band_hz
        if self.kind == "swept":
            from scipy.signal import chirp

            t = np.arange(n) / self.sample_rate
            return self.level_g * chirp(t, *self.sweep()[:1], t[-1], self.sweep()[1],
                                        method="logarithmic", phi=-90.0)
        f = np.fft.rfftfreq(n, 1.0 / self.sample_rate)
        inside = (f >= lo) & (f <= hi)
        spec = np.zeros(f.size, complex)
        spec[inside] = rng.normal(size=inside.sum()) + 1j * rng.normal(size=inside.sum())
        a = np.fft.irfft(spec, n)
        return a * (self.level_g / np.sqrt(np.mean(a**2)))

    def simulate(self, dut: DutResponse | None = None, *, seed=0, unit: str = "V",
                 metadata: dict | None = None) -> ResponseRecord:
        """A broadband record of ``dut``: one step, ``frequency`` 0 (random) or the sweep's."""
        dut = dut or DutResponse()
        rng = generator(seed)
        a = self.acceleration(rng)
        n = a.size
        f = np.fft.rfftfreq(n, 1.0 / self.sample_rate)
        table = self.reference.frequency_hz
        spec = np.fft.rfft(a)
        s_ref = self.reference.sensitivity(np.clip(f, table[0], table[-1]))
        daq = self.gain_ratio * np.exp(-2j * np.pi * f * self.delay_s)
        ref = np.fft.irfft(spec * s_ref, n)
        out = np.fft.irfft(spec * dut(f) * daq, n)
        if self.ref_noise:
            ref = ref + rng.normal(0.0, self.ref_noise, n)
        if self.noise:
            out = out + rng.normal(0.0, self.noise, n)
        t = np.arange(n) / self.sample_rate
        lo, hi = self.band_hz
        first, last = self.sweep()
        freq = np.zeros(n) if self.kind == "random" else first * (last / first) ** (t / t[-1])
        meta = {"excitation": {"kind": self.kind, "band_hz": [float(lo), float(hi)],
                               "level_g": float(self.level_g)},
                "reference": self.reference.to_dict(),
                "daq": {"gain_ratio": float(self.gain_ratio), "delay_s": float(self.delay_s)},
                "true": dut.to_dict(), "noise_v": float(self.noise),
                "ref_noise_v": float(self.ref_noise), "simulated": True, **(metadata or {})}
        cols = {"step": np.zeros(n), "frequency": freq, "t": t, "ref": ref, "dut": out}
        return _record(cols, self.sample_rate, unit, meta, seed)


def _stepped_checks(frequencies, periods, sample_rate, top) -> np.ndarray:
    f = np.asarray(frequencies, dtype=float)
    if not 1.0 <= sample_rate <= 1e8:
        raise AccelcalError(f"must be from 1 Hz to 1e8 Hz, got {sample_rate!r}",
                            parameter="sample_rate")
    if f.size == 0 or not np.all(f > 0) or np.any(f > top):
        raise AccelcalError(f"frequencies must be above 0 Hz and up to {top:g} Hz",
                            parameter="frequencies")
    if int(periods) != periods or periods < 1:
        raise AccelcalError("must be a whole number of periods >= 1", parameter="periods")
    samples = float(np.sum(periods * sample_rate / f))
    if samples > MAX_SAMPLES:
        raise AccelcalError(f"the steps would hold {samples:.3g} samples per channel, more "
                            f"than {MAX_SAMPLES:g}: fewer periods or a lower rate",
                            parameter="periods")
    work.simulated("response", f"{f.size} steps of {periods} periods at {sample_rate:g} Hz",
                   samples, parameter="periods", hint="give fewer periods or a lower rate")
    return f


@dataclass(frozen=True)
class LaserRig:
    """Primary calibration by a homodyne interferometer (ISO 16063-11, method 3).

    Attributes
    ----------
    frequencies : tuple of float
        Step frequencies, Hz.
    displacement_m : float
        Displacement amplitude of every step, m (the acceleration amplitude
        ``w^2 s / g`` follows).
    sample_rate : float
        Rate of the three channels (I, Q, DUT), Hz: the fringe rate ``4 pi
        s w / lambda`` rad/s must stay well below ``pi`` per sample.
    periods : int
        Whole periods per step.
    wavelength_m : float
        The laser's wavelength.
    ellipse : tuple of float
        ``(p, q, a, b, e)``: the quadrature signals' offsets (V), amplitudes (V)
        and quadrature error (rad).
    laser_noise : float
        White noise of I and Q, V rms.
    gain_ratio, delay_s : float
        The DUT channel's gain and delay relative to the interferometer's.
    distortion : tuple of float
        ``(d2, d3)``: the shaker's harmonics, fractions of the fundamental.
    noise : float
        White noise of the DUT channel, V rms.
    """

    frequencies: tuple = (100.0, 200.0, 400.0, 800.0, 1600.0)
    displacement_m: float = 2e-6
    sample_rate: float = 1e6
    periods: int = 20
    wavelength_m: float = HE_NE
    ellipse: tuple = (0.02, -0.015, 1.0, 0.9, 0.05)
    laser_noise: float = 1e-3
    gain_ratio: float = 1.0
    delay_s: float = 0.0
    distortion: tuple = (0.0, 0.0)
    noise: float = 1e-4

    def __post_init__(self) -> None:
        f = _stepped_checks(self.frequencies, self.periods, self.sample_rate,
                            self.sample_rate / 6)
        if not (1e-10 <= self.displacement_m <= 0.1 and 1e-7 <= self.wavelength_m <= 1e-4):
            raise AccelcalError("the displacement must be from 1e-10 to 0.1 m and the "
                                "wavelength from 1e-7 to 1e-4 m", parameter="displacement")
        if len(self.ellipse) != 5 or not (self.ellipse[2] > 0 and self.ellipse[3] > 0 and
                                          abs(self.ellipse[4]) < 1.0):
            raise AccelcalError("give the ellipse as p,q,a,b,e with a, b > 0 and |e| < 1 rad",
                                parameter="ellipse")
        if len(self.distortion) != 2 or not all(0 <= d < 1 for d in self.distortion):
            raise AccelcalError("give two harmonic fractions d2,d3 from 0 to below 1",
                                parameter="distortion")
        rate = 4 * np.pi * self.displacement_m * 2 * np.pi * f.max() / self.wavelength_m
        if rate * (1 + 2 * sum(self.distortion)) > 0.5 * np.pi * self.sample_rate:
            raise AccelcalError(f"the fringe rate {rate / (2 * np.pi):.3g} Hz at "
                                f"{f.max():g} Hz needs a sample rate above "
                                f"{4 * rate / (2 * np.pi):.3g} Hz", parameter="sample_rate")
        if not 0 <= self.laser_noise <= 1e3:
            raise AccelcalError("must be >= 0 (V rms)", parameter="laser_noise")
        _check_daq(self.gain_ratio, self.delay_s, self.noise)

    def amplitudes_g(self) -> np.ndarray:
        """Acceleration amplitude of each step, g."""
        w = 2 * np.pi * np.asarray(self.frequencies, float)
        return self.displacement_m * w**2 / G_N

    def simulate(self, dut: DutResponse | None = None, *, seed=0, unit: str = "V",
                 metadata: dict | None = None) -> ResponseRecord:
        """A laser record of ``dut``: ``ref`` = I, ``quadrature`` = Q, and the DUT."""
        dut = dut or DutResponse()
        rng = generator(seed)
        p, q, a_e, b_e, e = self.ellipse
        cols = {k: [] for k in ("step", "frequency", "t", "ref", "dut", "quadrature")}
        for k, (f, amp) in enumerate(zip(self.frequencies, self.amplitudes_g(), strict=True)):
            n = round(self.periods * self.sample_rate / f)
            t = np.arange(n) / self.sample_rate
            s = np.zeros(n)
            out = np.zeros(n)
            for h, d in ((1, 1.0), (2, self.distortion[0]), (3, self.distortion[1])):
                if d == 0.0:
                    continue
                w = 2 * np.pi * h * f
                carrier = -1j * amp * d * np.exp(1j * w * t)  # a(t) = A d sin(h w t), g
                s += np.real(carrier) * (-G_N / w**2)
                daq = self.gain_ratio * np.exp(-1j * w * self.delay_s)
                out += np.real(dut(h * f)[0] * daq * carrier)
            phi = 4 * np.pi * s / self.wavelength_m + 0.3
            i_sig = a_e * np.cos(phi) + p + rng.normal(0.0, self.laser_noise, n)
            q_sig = b_e * np.sin(phi + e) + q + rng.normal(0.0, self.laser_noise, n)
            out = out + rng.normal(0.0, self.noise, n) if self.noise else out
            for name, v in (("step", np.full(n, k)), ("frequency", np.full(n, float(f))),
                            ("t", t), ("ref", i_sig), ("dut", out), ("quadrature", q_sig)):
                cols[name].append(v)
        meta = {"excitation": {"kind": "laser", "wavelength_m": float(self.wavelength_m),
                               "ellipse": [float(x) for x in self.ellipse]},
                "amplitudes_g": [float(x) for x in self.amplitudes_g()],
                "daq": {"gain_ratio": float(self.gain_ratio), "delay_s": float(self.delay_s)},
                "true": dut.to_dict(), "noise_v": float(self.noise),
                "distortion": [float(d) for d in self.distortion], "simulated": True,
                **(metadata or {})}
        return _record({k: np.concatenate(v) for k, v in cols.items()}, self.sample_rate, unit,
                       meta, seed)


@dataclass(frozen=True)
class GravityRig:
    """Rotation about a horizontal axis at constant rates (ISO 16063-16).

    Attributes
    ----------
    frequencies : tuple of float
        Rotation frequencies, Hz (one step each).
    sample_rate : float
        Rate of the encoder and DUT channels, Hz.
    periods : int
        Whole turns per step.
    local_g : float
        Local gravity, g (units of standard gravity).
    bias_g, k2 : float
        The DUT's bias (g) and second-order coefficient (g/g^2), so that its
        input is ``bias + a + k2 a^2``.
    noise : float
        White noise of the DUT channel, V rms.
    """

    frequencies: tuple = (0.25, 0.5, 1.0, 2.0, 4.0)
    sample_rate: float = 1000.0
    periods: int = 4
    local_g: float = 1.0
    bias_g: float = 1e-3
    k2: float = 2e-5
    noise: float = 1e-4

    def __post_init__(self) -> None:
        _stepped_checks(self.frequencies, self.periods, self.sample_rate,
                        min(50.0, self.sample_rate / 6))
        if not 0.9 <= self.local_g <= 1.1:
            raise AccelcalError("must be from 0.9 to 1.1 g", parameter="local_g")
        if not (abs(self.bias_g) <= 1.0 and abs(self.k2) <= 1.0):
            raise AccelcalError("the bias and k2 must be within 1 g and 1 g/g^2",
                                parameter="bias")
        _check_daq(1.0, 0.0, self.noise)

    def simulate(self, dut: DutResponse | None = None, *, seed=0, unit: str = "V",
                 metadata: dict | None = None) -> ResponseRecord:
        """A rotation record of ``dut``: ``ref`` the encoder angle (rad), ``dut`` its output."""
        dut = dut or DutResponse()
        rng = generator(seed)
        cols = {k: [] for k in ("step", "frequency", "t", "ref", "dut")}
        for k, f in enumerate(self.frequencies):
            n = round(self.periods * self.sample_rate / f)
            t = np.arange(n) / self.sample_rate
            theta = 2 * np.pi * f * t + 0.4
            a1 = self.local_g * np.real(dut(f)[0] * np.exp(1j * theta))
            # a^2 = g^2 (1 + cos 2 theta) / 2: its 2 f part passes the sensitivity at 2 f
            a2 = 0.5 * self.k2 * self.local_g**2 * (
                dut(0.0)[0].real + np.real(dut(2 * f)[0] * np.exp(2j * theta)))
            out = a1 + a2 + self.bias_g * dut(0.0)[0].real
            out = out + rng.normal(0.0, self.noise, n) if self.noise else out
            for name, v in (("step", np.full(n, k)), ("frequency", np.full(n, float(f))),
                            ("t", t), ("ref", theta), ("dut", out)):
                cols[name].append(v)
        meta = {"excitation": {"kind": "gravity", "local_g": float(self.local_g)},
                "amplitudes_g": [float(self.local_g)] * len(self.frequencies),
                "true": dut.to_dict(), "noise_v": float(self.noise), "simulated": True,
                "bias_g": float(self.bias_g), "k2": float(self.k2), **(metadata or {})}
        return _record({k: np.concatenate(v) for k, v in cols.items()}, self.sample_rate, unit,
                       meta, seed)
