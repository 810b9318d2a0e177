"""A shaker for frequency response by comparison (ISO 16063-21): reference and DUT back to back.

:mod:`accelcal.rigs.shaker` serves the transverse test (the sensor turned
in its transverse plane, one frequency); this rig serves the frequency
response: the device under test (DUT) rides on a reference accelerometer,
the shaker steps through a list of frequencies and amplitudes, and a
two-channel DAQ samples both outputs over whole periods of each step.

The reference's complex sensitivity comes from its own certificate, a table
against frequency (:class:`ReferenceTable`, magnitude and phase interpolated
linearly in frequency); the DUT's is the force-rebalance transfer function
of :mod:`accelcal.physics.response` (:class:`DutResponse`). The excitation
of a step of frequency ``f`` and amplitude ``A`` (g) is::

    a(t) = A [sin(w t) + d2 sin(2 w t) + d3 sin(3 w t)],   w = 2 pi f,

(``d2``, ``d3`` the shaker's harmonic distortion), in steady state; each
harmonic passes each sensor's sensitivity at its own frequency. The DUT
moves relative to the reference by the complex fraction ``rho`` of the
axial motion (mounting, base strain) and feels a transverse acceleration
``tau`` of it along its most sensitive transverse axis, which its
transverse sensitivity ``s_T`` adds to its output: the DUT's input is
``(1 + rho + s_T tau)`` times the reference's. The DUT's
channel of the DAQ has a gain ratio and a delay relative to the
reference's (multiplying its phasors by ``g exp(-i w tau)``), and each
channel adds white Gaussian noise. The record states the DUT's true
transfer function, the reference table and the DAQ mismatch in its
metadata; ``noise=0`` gives an exact record.

References
----------
.. [ISO16063-21] ISO 16063-21:2003, Vibration calibration by comparison to
   a reference transducer.
"""

from dataclasses import dataclass, field

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.response import ResponseRecord
from accelcal.physics.response import transfer
from accelcal.resources import generator

DEFAULT_FREQUENCIES = (10.0, 20.0, 40.0, 80.0, 160.0, 315.0, 500.0, 630.0, 800.0, 1000.0,
                       1250.0)
"""Steps of the default campaign, Hz (ISO 266 preferred frequencies up to 1.25 kHz)."""


MAX_SAMPLES = 5e7
"""Most samples per channel of a simulated campaign (two channels of 400 MB in memory)."""


@dataclass(frozen=True)
class ReferenceTable:
    """A reference accelerometer's certificate: complex sensitivity against frequency.

    Attributes
    ----------
    frequency_hz : tuple of float
        Increasing frequencies, Hz.
    magnitude : tuple of float
        Sensitivity magnitude, V/g.
    phase_deg : tuple of float
        Phase, deg (output lagging input is negative).
    magnitude_U, phase_U : tuple of float
        Expanded uncertainties (k = 2), V/g and deg.
    """

    frequency_hz: tuple
    magnitude: tuple
    phase_deg: tuple
    magnitude_U: tuple = ()
    phase_U: tuple = ()

    def __post_init__(self) -> None:
        f = np.asarray(self.frequency_hz, dtype=float)
        n = f.size
        sizes = {len(self.magnitude), len(self.phase_deg)}
        sizes |= {len(x) for x in (self.magnitude_U, self.phase_U) if len(x)}
        if n < 2 or sizes != {n}:
            raise AccelcalError("a reference table needs at least two frequencies and one "
                                "magnitude and phase (and U, if given) per frequency")
        if not (np.all(np.isfinite(f)) and np.all(np.diff(f) > 0) and f[0] > 0):
            raise AccelcalError("a reference table's frequencies must be positive and "
                                "increasing")
        mag = np.asarray(self.magnitude, dtype=float)
        if not np.all(mag > 0) or not np.all(np.isfinite(np.asarray(self.phase_deg, float))):
            raise AccelcalError("a reference table's magnitudes must be positive and its "
                                "phases finite")

    def sensitivity(self, f) -> np.ndarray:
        """Complex sensitivity (V/g) at frequencies ``f``, interpolated linearly.

        Raises
        ------
        AccelcalError
            For a frequency outside the table (it is not extrapolated).
        """
        f = np.atleast_1d(np.asarray(f, dtype=float))
        lo, hi = self.frequency_hz[0], self.frequency_hz[-1]
        out = f[(f < lo * (1 - 1e-12)) | (f > hi * (1 + 1e-12))]
        if out.size:
            raise AccelcalError(f"the reference table covers {lo:g}-{hi:g} Hz, not {out[0]:g} "
                                "Hz: give a reference certificate that covers the band",
                                parameter="reference")
        mag = np.interp(f, self.frequency_hz, self.magnitude)
        phase = np.interp(f, self.frequency_hz, self.phase_deg)
        return mag * np.exp(1j * np.deg2rad(phase))

    def to_dict(self) -> dict:
        """The table as the record's ``reference`` metadata (lists)."""
        out = {"frequency_hz": list(map(float, self.frequency_hz)),
               "magnitude": list(map(float, self.magnitude)),
               "phase_deg": list(map(float, self.phase_deg))}
        if len(self.magnitude_U):
            out |= {"magnitude_U": list(map(float, self.magnitude_U)),
                    "phase_U": list(map(float, self.phase_U))}
        return out

    @classmethod
    def from_dict(cls, data) -> "ReferenceTable":
        """The table of a record's ``reference`` metadata or a certificate's columns."""
        if not isinstance(data, dict) or not {"frequency_hz", "magnitude", "phase_deg"} <= set(
                data):
            raise AccelcalError("a reference table needs frequency_hz, magnitude and phase_deg",
                                parameter="reference")
        try:
            return cls(*(tuple(float(x) for x in data.get(k, ())) for k in
                         ("frequency_hz", "magnitude", "phase_deg", "magnitude_U", "phase_U")))
        except (TypeError, ValueError):
            raise AccelcalError("a reference table's entries must be numbers",
                                parameter="reference") from None


def default_reference() -> ReferenceTable:
    """A back-to-back reference (about 10 mV/g behind its amplifier set to 10x: 0.1 V/g).

    Flat to 0.3 % up to 5 kHz, rising slowly towards its mounted resonance,
    with a phase lag of 0.05 deg per kHz; U = 0.5 % and 0.5 deg (k = 2).
    """
    f = np.array([1.0, 5.0, 10.0, 20.0, 40.0, 80.0, 160.0, 315.0, 630.0, 1000.0, 2000.0,
                  3150.0, 5000.0, 10000.0])
    mag = 0.1 * (1.0 + 0.003 * (f / 5000.0) ** 2)
    return ReferenceTable(tuple(f), tuple(mag), tuple(-0.05 * f / 1000.0),
                          tuple(0.005 * mag), tuple(np.full(f.size, 0.5)))


@dataclass(frozen=True)
class DutResponse:
    """A force-rebalance accelerometer's transfer function.

    Evaluated by :func:`accelcal.physics.response.transfer`.

    Attributes
    ----------
    S0 : float
        Static sensitivity, output unit per g.
    fn_hz : float
        Natural frequency of the loop, Hz.
    zeta : float
        Damping ratio.
    pole_hz : float or None
        Extra real pole, Hz.
    delay_s : float
        Pure delay, s.
    """

    S0: float = 1.3
    fn_hz: float = 600.0
    zeta: float = 0.6
    pole_hz: float | None = None
    delay_s: float = 0.0

    def __post_init__(self) -> None:
        checks = (("s0", self.S0, 0 < abs(self.S0) <= 1e6, "non-zero, magnitude up to 1e6"),
                  ("fn", self.fn_hz, 1e-3 <= self.fn_hz <= 1e7, "from 1e-3 to 1e7 Hz"),
                  ("zeta", self.zeta, 1e-6 <= self.zeta <= 1e3, "from 1e-6 to 1e3"),
                  ("pole", self.pole_hz,
                   self.pole_hz is None or 1e-3 <= self.pole_hz <= 1e7, "from 1e-3 to 1e7 Hz"),
                  ("delay", self.delay_s, abs(self.delay_s) <= 1.0, "within 1 s"))
        for name, value, ok, text in checks:
            if not ok:
                raise AccelcalError(f"must be {text}, got {value!r}", parameter=name)

    def __call__(self, f) -> np.ndarray:
        """Complex sensitivity at frequencies ``f``, Hz."""
        return transfer(f, self.S0, self.fn_hz, self.zeta, pole_hz=self.pole_hz,
                        delay_s=self.delay_s)

    def to_dict(self) -> dict:
        """The record's ``true`` metadata."""
        return {"S0": float(self.S0), "fn_hz": float(self.fn_hz), "zeta": float(self.zeta),
                "pole_hz": None if self.pole_hz is None else float(self.pole_hz),
                "delay_s": float(self.delay_s)}


@dataclass(frozen=True)
class ResponseRig:
    """A stepped-sine comparison: shaker, reference, DUT and a two-channel DAQ.

    Attributes
    ----------
    frequencies : tuple of float
        Step frequencies, Hz.
    amplitudes : tuple of float
        Acceleration amplitude of each step, g (one value: every step).
    sample_rate : float
        Sample rate of both channels, Hz.
    periods : int
        Whole periods recorded per step.
    reference : ReferenceTable
        The reference's certificate (also its true sensitivity here).
    gain_ratio, delay_s : float
        The DUT channel's gain relative to the reference's and its delay, s.
    distortion : tuple of float
        ``(d2, d3)``: second and third harmonic of the shaker's motion,
        fractions of the fundamental.
    noise : float
        White noise of each channel, V rms (0: an exact record).
    relative_motion : tuple of float
        ``(Re, Im)`` of ``rho``: the DUT's motion relative to the
        reference's, fraction of the axial.
    transverse : tuple of float
        ``(Re, Im)`` of ``tau``: the transverse acceleration along the DUT's
        most sensitive transverse axis, fraction of the axial.
    transverse_sensitivity : float
        ``s_T``: the DUT's transverse sensitivity, fraction of its axial.
    """

    frequencies: tuple = DEFAULT_FREQUENCIES
    amplitudes: tuple = (1.0,)
    sample_rate: float = 20000.0
    periods: int = 20
    reference: ReferenceTable = field(default_factory=default_reference)
    gain_ratio: float = 1.0
    delay_s: float = 0.0
    distortion: tuple = (0.0, 0.0)
    noise: float = 1e-4
    relative_motion: tuple = (0.0, 0.0)
    transverse: tuple = (0.0, 0.0)
    transverse_sensitivity: float = 0.0

    def __post_init__(self) -> None:
        f = np.asarray(self.frequencies, dtype=float)
        for name in ("relative_motion", "transverse"):
            pair = getattr(self, name)
            if len(pair) != 2 or not all(np.isfinite(x) and abs(x) < 1 for x in pair):
                raise AccelcalError("give Re,Im, each of magnitude below 1", parameter=name)
        if not 0 <= self.transverse_sensitivity < 1:
            raise AccelcalError("must be from 0 to below 1", parameter="transverse_sensitivity")
        if not 1.0 <= self.sample_rate <= 1e7:
            raise AccelcalError(f"must be from 1 Hz to 1e7 Hz, got {self.sample_rate!r}",
                                parameter="sample_rate")
        if not (0 < self.gain_ratio <= 1e6 and abs(self.delay_s) <= 1.0):
            raise AccelcalError("the DAQ's gain ratio must be in (0, 1e6] and its delay within "
                                "1 s", parameter="gain_ratio")
        if len(self.distortion) != 2 or not all(0 <= d < 1 for d in self.distortion):
            raise AccelcalError("give two harmonic fractions d2,d3 from 0 to below 1",
                                parameter="distortion")
        if f.size == 0 or not np.all(f > 0) or np.any(f >= self.sample_rate / 6):
            raise AccelcalError(f"step frequencies must be above 0 Hz and their third harmonic "
                                f"below the Nyquist frequency {self.sample_rate / 2:g} Hz",
                                parameter="frequencies")
        if len(self.amplitudes) not in (1, f.size) or not all(a > 0 for a in self.amplitudes):
            raise AccelcalError("give one positive amplitude, or one per step",
                                parameter="amplitudes")
        if int(self.periods) != self.periods or self.periods < 1:
            raise AccelcalError("must be a whole number of periods >= 1", parameter="periods")
        samples = float(np.sum(self.periods * self.sample_rate / f))
        if samples > MAX_SAMPLES:
            raise AccelcalError(f"the steps would hold {samples:.3g} samples per channel, more "
                                f"than {MAX_SAMPLES:g}: fewer periods or a lower rate",
                                parameter="periods")
        work.simulated("response", f"{f.size} steps of {self.periods} periods at "
                       f"{self.sample_rate:g} Hz", samples, parameter="periods",
                       hint="give fewer periods or a lower rate")
        if not 0 <= self.noise <= 1e6:
            raise AccelcalError("must be >= 0 (V rms)", parameter="noise")
        self.reference.sensitivity(f)  # the band is covered

    def step_amplitudes(self) -> np.ndarray:
        """Amplitude of each step, g."""
        return np.broadcast_to(np.asarray(self.amplitudes, float), (len(self.frequencies),))

    def channels(self, dut: DutResponse, f: float, amplitude: float, t: np.ndarray):
        """Noise-free reference and DUT outputs at times ``t`` of a step (closed form).

        A harmonic above the reference table sees the table's last sensitivity.
        """
        d2, d3 = self.distortion
        ref = np.zeros_like(t)
        out = np.zeros_like(t)
        top = self.reference.frequency_hz[-1]
        moved = 1.0 + complex(*self.relative_motion) + self.transverse_sensitivity * complex(
            *self.transverse)
        for k, d in ((1, 1.0), (2, d2), (3, d3)):
            if d == 0.0:
                continue
            w = 2.0 * np.pi * k * f
            carrier = -1j * amplitude * d * np.exp(1j * w * t)  # A sin(w t) = Re(-i A e^(iwt))
            daq = self.gain_ratio * np.exp(-1j * w * self.delay_s)
            ref += np.real(self.reference.sensitivity(min(k * f, top))[0] * carrier)
            out += np.real(dut(k * f)[0] * daq * moved * carrier)
        return ref, out

    def simulate(self, dut: DutResponse | None = None, *, seed=0, unit: str = "V",
                 metadata: dict | None = None, progress=None) -> ResponseRecord:
        """A stepped-sine record of ``dut`` (default :class:`DutResponse`).

        Parameters
        ----------
        dut : DutResponse, optional
            The device under test.
        seed : int, SeedSequence or Generator
            The noise's seed.
        unit : str
            The DUT channel's unit (``V``, ``mV``, ``mA``; S0 is in it per g).
        metadata : dict, optional
            Further metadata (laboratory fields).
        progress : callable, optional
            Called as ``progress(steps done, steps)`` after each step.

        Returns
        -------
        accelcal.io.formats.response.ResponseRecord
            Columns ``step, frequency, t, ref, dut``; metadata ``true``,
            ``reference``, ``daq``, ``amplitudes_g``, ``noise_v``,
            ``simulated`` (and ``mounting``: the relative and transverse
            motion, when not zero).
        """
        dut = dut or DutResponse()
        rng = generator(seed)
        cols = {"step": [], "frequency": [], "t": [], "ref": [], "dut": []}
        amps = self.step_amplitudes()
        for k, (f, amp) in enumerate(zip(self.frequencies, amps, strict=True)):
            n = round(self.periods * self.sample_rate / f)
            t = np.arange(n) / self.sample_rate
            ref, out = self.channels(dut, f, amp, t)
            if self.noise:
                ref = ref + rng.normal(0.0, self.noise, n)
                out = out + rng.normal(0.0, self.noise, n)
            for name, v in (("step", np.full(n, k)), ("frequency", np.full(n, float(f))),
                            ("t", t), ("ref", ref), ("dut", out)):
                cols[name].append(v)
            if progress is not None:
                progress(k + 1, len(amps))
        meta = {"amplitudes_g": [float(a) for a in amps], "reference": self.reference.to_dict(),
                "daq": {"gain_ratio": float(self.gain_ratio), "delay_s": float(self.delay_s)},
                "true": dut.to_dict(), "noise_v": float(self.noise),
                "distortion": [float(d) for d in self.distortion], "simulated": True,
                **(metadata or {})}
        mounting = {"relative_motion": [float(x) for x in self.relative_motion],
                    "transverse": [float(x) for x in self.transverse],
                    "transverse_sensitivity": float(self.transverse_sensitivity)}
        if any(np.any(v) for v in mounting.values()):  # the truth, beside the DAQ's
            meta["mounting"] = mounting
        if isinstance(seed, int):
            meta["seed"] = seed
        return ResponseRecord(**{k: np.concatenate(v) for k, v in cols.items()},
                              sample_rate_hz=float(self.sample_rate), output_unit=unit,
                              metadata=meta)


def simulate(dut: DutResponse | None = None, *, seed=0, unit: str = "V", metadata=None,
             **settings) -> ResponseRecord:
    """:meth:`ResponseRig.simulate` of a rig of ``settings`` (:class:`ResponseRig`'s fields)."""
    return ResponseRig(**settings).simulate(dut, seed=seed, unit=unit, metadata=metadata)
