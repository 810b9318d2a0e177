"""Shaker rig: sinusoidal vibration in the transverse plane of an accelerometer.

Frame (DOMAIN conventions, GuanTang Fig. 1): IA = Z, OA = Y, PA = X. The
shaker vibrates along a direction at angle ``theta`` in the XY plane,
measured from PA towards OA, so the unit vector of the vibration axis in
(PA, OA, IA) components is ``(cos theta, sin theta, 0)``.

The specific force the accelerometer feels is ::

    f(t) = (G + a_v(t)) e_v + a_n(t) e_n + a_ia(t) e_i,
    a_v(t) = A_v sin(w t + phi)                                   (GuanTang eq. (5))

with ``G`` the static gravity component along the vibration axis (0 is the
paper's idealised set-up, 1 the physical vertical shaker with IA horizontal:
the drive law (4) cannot remove gravity from the sensed specific force),
``e_n = (-sin theta, cos theta, 0)`` the in-plane direction perpendicular to
the vibration axis and ``e_i`` the input axis. The shaker's own transverse
motion has amplitude ``ratio * A_v``, phase ``phase`` relative to ``a_v``
and direction ``beta`` in the plane perpendicular to the vibration axis,
from ``e_n`` towards IA: ``a_n = ratio A_v cos(beta) sin(w t + phi + psi)``,
``a_ia = ratio A_v sin(beta) sin(w t + phi + psi)``. In the laboratory this
plane is horizontal and does not turn with the accelerometer about IA.

The reference accelerometer measures ``a_v`` (column ``ref``); optionally
the transverse motion too (``ref_n``, ``ref_ia``). The simulated records are
:class:`accelcal.io.formats.shaker.ShakerRecords`; that module reads and
writes their files.

References
----------
.. [GuanTang] Guan W., Tang L., Shaker test method of transverse sensitivity
   of inertial accelerometers, eqs. (1)-(6), (14), Figs. 1-2.
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration
   sensitivity (shaker method).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.io.formats.shaker import MAX_MAGNITUDE, ShakerRecords
from accelcal.model import MAX_SPECIFIC_FORCE_G, ErrorModel
from accelcal.resources import check_memory, seeded
from accelcal.units import OUTPUT_UNITS

MEMORY_FACTOR = 20
"""Arrays of (angles x samples) float64 a simulation holds at its peak, per trial:
13 measured (tracemalloc) with every channel and the output at rest, 16 with
stacked trials, 6 while the files are written; 20 leaves a margin."""


@dataclass(frozen=True)
class LinearModel:
    """Linear model of a vibration accelerometer: ``u = s_i a_i + s_o a_o + s_p a_p``.

    Parameters
    ----------
    s_i, s_o, s_p : float
        Sensitivities along IA, OA and PA in the output unit per g.
    output_unit : {"V", "mV", "mA", "g"}
        Output unit.
    sigma : float
        Output noise standard deviation in g (scaled by ``s_i``).

    References
    ----------
    .. [1] GuanTang, eq. (2); ISO 16063-31.
    """

    s_i: float
    s_o: float = 0.0
    s_p: float = 0.0
    output_unit: str = "mV"
    sigma: float = 0.0

    def __post_init__(self) -> None:
        for name in ("s_i", "s_o", "s_p", "sigma"):
            if not np.isfinite(getattr(self, name)):
                raise AccelcalError(f"LinearModel {name} must be finite")
        if self.s_i == 0.0:
            raise AccelcalError("LinearModel s_i (axial sensitivity) must be non-zero")
        if self.sigma < 0:
            raise AccelcalError("LinearModel sigma must be >= 0")
        if self.output_unit not in OUTPUT_UNITS:
            raise AccelcalError(f"LinearModel output_unit must be one of {OUTPUT_UNITS}")

    @property
    def K1(self) -> float:
        """Axial sensitivity, output unit per g (the analogue of ErrorModel.K1)."""
        return self.s_i

    def output(self, a_i, a_o=0.0, a_p=0.0, *, rng=None):
        """Output in the output unit; Eq. (2) [GuanTang]."""
        u = self.s_i * np.asarray(a_i, float) + self.s_o * np.asarray(a_o, float)
        u = u + self.s_p * np.asarray(a_p, float)  # Eq. (2) [GuanTang]
        if rng is not None and self.sigma > 0:
            u = u + rng.normal(0.0, self.sigma * abs(self.s_i), size=np.shape(u))
        return u


Sensor = ErrorModel | LinearModel


@dataclass(frozen=True)
class ShakerRig:
    """A shaker vibrating along a direction in the transverse plane.

    Parameters
    ----------
    amplitude : float
        Vibration amplitude A_v, g (>= 0).
    frequency : float
        Vibration frequency f, Hz.
    sample_rate : float
        Sample rate, Hz (above 4 f so that the 2w component is resolved).
    periods : float
        Record length in periods; a non-integer gives a partial last period.
    phase : float
        Initial phase phi of ``a_v = A_v sin(w t + phi)``, rad.
    gravity : float
        Static specific force along the vibration axis, g (0 or 1 typically).
    transverse_ratio : float
        Amplitude of the shaker's own transverse motion relative to A_v
        (>= 0: a magnitude; its sign is set by ``transverse_phase`` and
        ``transverse_direction``).
    transverse_phase : float
        Its phase relative to ``a_v``, rad.
    transverse_direction : float
        Its direction beta from ``e_n`` towards IA, rad.
    ref_noise : float
        Noise of the reference channels, g (standard deviation).
    noise : float, optional
        Sensor output noise in g (scaled by the axial scale factor); default
        the sensor's own ``sigma``.
    measure_transverse : bool
        Record reference channels ``ref_n`` and ``ref_ia`` of the transverse motion.
    rest : bool
        Also record the output at rest (``u_rest``, same length) at each angle.

    References
    ----------
    .. [1] GuanTang, eqs. (4)-(6) and (14); ISO 16063-31.
    """

    amplitude: float
    frequency: float = 160.0
    sample_rate: float = 10240.0
    periods: float = 16.0
    phase: float = 0.0
    gravity: float = 0.0
    transverse_ratio: float = 0.0
    transverse_phase: float = 0.0
    transverse_direction: float = 0.0
    ref_noise: float = 0.0
    noise: float | None = None
    measure_transverse: bool = False
    rest: bool = False

    def __post_init__(self) -> None:
        for name in ("amplitude", "frequency", "sample_rate", "periods", "phase", "gravity",
                     "transverse_ratio", "transverse_phase", "transverse_direction",
                     "ref_noise"):
            if not np.isfinite(getattr(self, name)):
                raise AccelcalError(f"shaker: {name} must be finite")
        if self.amplitude < 0:
            raise AccelcalError(f"shaker: amplitude {self.amplitude} g must be >= 0")
        if self.frequency <= 0 or self.sample_rate <= 0:
            raise AccelcalError("shaker: frequency and sample rate must be positive (Hz)")
        if self.sample_rate <= 4 * self.frequency:
            raise AccelcalError(
                f"shaker: sample rate {self.sample_rate} Hz must exceed 4 f = "
                f"{4 * self.frequency} Hz to resolve the 2w component"
            )
        if self.periods < 1:
            raise AccelcalError(
                f"shaker: {self.periods} periods is shorter than one period; record at least one"
            )
        if self.ref_noise < 0 or (self.noise is not None and not self.noise >= 0):
            raise AccelcalError("shaker: noise levels must be >= 0 (g)")
        if self.noise is not None and not np.isfinite(self.noise):
            raise AccelcalError("shaker: noise must be finite")
        if self.transverse_ratio < 0:
            raise AccelcalError(
                f"{self.transverse_ratio:g} is negative; the shaker's transverse motion is a "
                "magnitude relative to the vibration (>= 0): reverse it with the transverse "
                "phase (+180 deg) instead", parameter="transverse_ratio")
        self._check_specific_force()
        self._check_size(1)  # before the rates' bound: its message says more
        for name in ("frequency", "sample_rate"):
            if getattr(self, name) > MAX_MAGNITUDE:
                raise AccelcalError(f"{getattr(self, name):.6g} Hz is beyond the "
                                    f"{MAX_MAGNITUDE:g} Hz a shaker record holds",
                                    parameter=name)

    def _check_specific_force(self) -> None:
        """Refuse inputs beyond the specific force a sensor model is evaluated at.

        Checked here, naming the rig's parameters, before the model would
        refuse its inputs ``a_i``, ``a_o``, ``a_p`` in its own words. The
        peak is bounded by ``|G| + A_v (1 + ratio)`` (Eq. (6) [GuanTang]).
        """
        limit = MAX_SPECIFIC_FORCE_G
        peak = abs(self.gravity) + self.amplitude * (1.0 + self.transverse_ratio)
        for name, what, value in (
            ("amplitude", "amplitude", self.amplitude),
            ("gravity", "gravity", abs(self.gravity)),
            ("transverse_ratio", "the transverse motion (ratio x amplitude)",
             self.transverse_ratio * self.amplitude),
            ("amplitude", "the peak specific force", peak),
        ):
            if value > limit:
                raise AccelcalError(
                    f"{what} of {value:.3g} g is beyond the {limit:.0e} g a sensor model is "
                    "evaluated at; give smaller values, in g", parameter=name)
        for name in ("noise", "ref_noise"):
            value = getattr(self, name)
            if value is not None and value > MAX_MAGNITUDE:
                raise AccelcalError(f"{value:.3g} g is beyond the {MAX_MAGNITUDE:g} a shaker "
                                    "record holds (and any physical test)", parameter=name)

    def _check_size(self, channels: float) -> None:
        """Refuse records of ``channels`` x samples that would not fit in memory."""
        check_memory(self.periods * self.sample_rate / self.frequency, channels, MEMORY_FACTOR,
                     f"shaker records of {self.periods:g} periods of {self.frequency:g} Hz at "
                     f"{self.sample_rate:g} Hz", hint="record fewer periods or sample slower")

    @property
    def samples(self) -> int:
        """Samples per record, ``round(periods fs / f)``."""
        return round(self.periods * self.sample_rate / self.frequency)

    def time(self) -> np.ndarray:
        """Sample times, s."""
        return np.arange(self.samples) / self.sample_rate

    def inputs(self, theta):
        """Specific force (a_i, a_o, a_p) and reference signals at angles ``theta``.

        Parameters
        ----------
        theta : array_like, shape (m,)
            Direction angles, rad.

        Returns
        -------
        (a_i, a_o, a_p), (a_v, a_n, a_ia) : tuples of numpy.ndarray, shape (m, n)
            Specific force components in g, and the vibration and transverse
            motion signals in g.

        References
        ----------
        .. [1] GuanTang, eqs. (5)-(6) [DOMAIN section 3], gravity as a static component.
        """
        theta = np.atleast_1d(np.asarray(theta, dtype=float))[:, None]
        self._check_size(theta.size)
        wt = 2 * np.pi * self.frequency * self.time()
        a_v = self.amplitude * np.sin(wt + self.phase) + 0.0 * theta  # Eq. (5) [GuanTang]
        motion = self.transverse_ratio * self.amplitude * np.sin(
            wt + self.phase + self.transverse_phase
        )
        a_n = np.cos(self.transverse_direction) * motion + 0.0 * theta
        a_ia = np.sin(self.transverse_direction) * motion + 0.0 * theta
        axial = self.gravity + a_v
        # Eq. (6) [GuanTang]: a_p = a cos(theta), a_o = a sin(theta), plus e_n, e_i parts.
        a_p = axial * np.cos(theta) - a_n * np.sin(theta)
        a_o = axial * np.sin(theta) + a_n * np.cos(theta)
        return (a_ia, a_o, a_p), (a_v, a_n, a_ia)

    def simulate(self, sensor: Sensor, theta, *, seed=None,
                 rng: np.random.Generator | None = None,
                 trials: int | None = None) -> ShakerRecords:
        """Simulate records at direction angles ``theta`` (rad).

        Parameters
        ----------
        sensor : ErrorModel or LinearModel
            The accelerometer.
        theta : array_like, shape (m,)
            Direction angles, rad.
        seed : int, numpy.random.SeedSequence or numpy.random.Generator, optional
            Source of noise; without it (and ``rng``) the records are noise-free.
        rng : numpy.random.Generator, optional
            The older name of ``seed`` (a Generator), kept as an alias.
        trials : int, optional
            Independent noise realisations stacked on a leading axis.

        Returns
        -------
        ShakerRecords
            Its metadata says ``"simulated": true`` (written into every file).

        Raises
        ------
        AccelcalError
            When the records would not fit in memory, or overflow.
        """
        rng = seeded(seed, rng)
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        lead = () if trials is None else (int(trials),)
        self._check_size(theta.size * (1 if trials is None else int(trials)))
        with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused below
            return self._simulate(sensor, theta, rng, lead)

    def _simulate(self, sensor: Sensor, theta, rng, lead) -> ShakerRecords:
        (a_i, a_o, a_p), (a_v, a_n, a_ia) = self.inputs(theta)
        shape = (*lead, *a_v.shape)
        u = np.broadcast_to(sensor.output(a_i, a_o, a_p), shape)
        static = np.zeros_like(a_v) + self.gravity
        u_rest = None
        if self.rest:
            u_rest = np.broadcast_to(
                sensor.output(0.0 * static, static * np.sin(theta)[:, None],
                              static * np.cos(theta)[:, None]), shape)
        chans = {"ref": a_v, "ref_n": a_n, "ref_ia": a_ia}
        chans = {k: np.broadcast_to(v, shape) for k, v in chans.items()}
        sigma = sensor.sigma if self.noise is None else self.noise
        if rng is not None:
            scale = abs(sensor.K1) * sigma
            if scale > 0:
                u = u + rng.normal(0.0, scale, size=shape)
                if u_rest is not None:
                    u_rest = u_rest + rng.normal(0.0, scale, size=shape)
            if self.ref_noise > 0:
                chans = {k: v + rng.normal(0.0, self.ref_noise, size=shape)
                         for k, v in chans.items()}
        signals = [u, *chans.values(), *(() if u_rest is None else (u_rest,))]
        if not all(np.abs(x).max() <= MAX_MAGNITUDE for x in signals):
            raise AccelcalError(
                f"shaker: the simulated signals overflow (exceed the {MAX_MAGNITUDE:g} a shaker "
                "record holds, or are not finite): the amplitude, gravity, noise or sensor "
                "coefficients are beyond any physical test; give smaller values")
        meta = {
            "sensor": "linear" if isinstance(sensor, LinearModel) else "inertial",
            "phase_rad": self.phase,
            "transverse_ratio": self.transverse_ratio,
            "transverse_phase_rad": self.transverse_phase,
            "transverse_direction_rad": self.transverse_direction,
            "simulated": True,
        }
        return ShakerRecords(
            t=self.time(), theta=theta, ref=chans["ref"], u=np.array(u),
            frequency=self.frequency, sample_rate=self.sample_rate, amplitude=self.amplitude,
            gravity=self.gravity, output_unit=sensor.output_unit, scale_factor=float(sensor.K1),
            ref_n=chans["ref_n"] if self.measure_transverse else None,
            ref_ia=chans["ref_ia"] if self.measure_transverse else None,
            u_rest=None if u_rest is None else np.array(u_rest), metadata=meta,
        )
