"""Thermal-chamber rig: plateaus and ramps, a lagging sensor, a tumble at each plateau.

The chamber's air temperature ``Tc(t)`` follows a programme: the sensor is
turned on at ``start`` and read at a fixed position for ``warmup`` seconds,
then for each setpoint the chamber ramps at ``ramp_rate`` (degC/min), holds
(``soak`` s, sensor at a fixed position) and a multipoint tumble is run
(``points`` positions, ``dwell`` s each). The sensor's own temperature
lags the air as a first-order system::

    tau dTs/dt = Tc - Ts                                      # Eq. (1) [Lag]

discretised exactly for an input linear between samples (first-order hold,
exact here because every ramp starts and ends on a sample)::

    Ts[n+1] = a Ts[n] + b0 Tc[n] + b1 Tc[n+1],  a = exp(-h/tau),
    b1 = 1 - (tau/h)(1 - a),  b0 = (tau/h)(1 - a) - a          # Eq. (2) [FOH]

and the output is the error model at the sensor temperature (its
temperature terms, :class:`~accelcal.terms.TemperatureTerms`) plus, in g and
times K1(T): a warm-up transient ``A exp(-t/tau_w)`` [DOMAIN 8], a
hysteresis ``+-h/2`` (bias) and ``+-hs K1/2`` (scale factor) after a
heating (+) or cooling (-) ramp, a thermal-transient term ``k dTs/dt``, and
white noise per reading.

References
----------
.. [Lag] Ogata K., Modern Control Engineering, 5th ed., sec. 5-3 (first-order
   systems: step and ramp responses).
.. [FOH] Franklin G. F., Powell J. D., Workman M. L., Digital Control of
   Dynamic Systems, 3rd ed., sec. 6.3.2 (first-order-hold equivalent).
.. [DOMAIN] accelcal domain notes, section 8 (thermal tests).
.. [IEEE1293] IEEE Std 1293-2018, thermal tests.
"""

from dataclasses import dataclass

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.thermal import PHASES, ThermalRecord
from accelcal.model import ErrorModel
from accelcal.physics.tumble import specific_force
from accelcal.resources import check_memory, generator
from accelcal.terms import TemperatureTerms, check_temperature

MEMORY_FACTOR = 16
"""float64 arrays per simulation step held at the peak (grid, chamber, sensor, rates,
outputs and the record's columns)."""

DEFAULT_TEMPERATURE = TemperatureTerms(25.0, {"K0_T1": 8e-6, "K0_T2": 3e-8, "K1_T1": -2.5e-5,
                                             "K1_T2": 8e-8, "Kp_T1": 1e-7})
"""Temperature terms of the simulated default accelerometer: bias TC 8 ug/degC, scale-factor
TC -25 ppm/degC, with second-order terms and a misalignment TC of 0.1 urad/degC."""


MAX_STEPS = 1e8
"""Most simulation steps of a programme (1e8: 800 MB per float64 array; a 10-day
programme at 10 ms steps)."""


@dataclass(frozen=True)
class Programme:
    """The chamber programme and the tumble at each plateau.

    Attributes
    ----------
    setpoints : tuple of float
        Plateau temperatures, degC, in test order.
    start : float
        Temperature at turn-on (the chamber and the sensor), degC.
    ramp_rate : float
        Ramp rate, degC/min (each ramp is rounded up to whole steps).
    soak : float
        Hold before each tumble, s (the sensor at ``angle0``).
    warmup : float
        Readings after turn-on before the first ramp, s.
    points : int
        Tumble positions (uniform from ``angle0``).
    dwell : float
        Time at each tumble position, s.
    step : float
        Reading interval and simulation step, s (soak, warm-up and dwell
        are whole multiples of it).
    angle0 : float
        The fixed position of warm-up and soak, and the first tumble
        position, rad.
    """

    setpoints: tuple = (-40.0, -10.0, 20.0, 50.0, 70.0, 35.0, 5.0, -25.0)
    start: float = 25.0
    ramp_rate: float = 1.0
    soak: float = 3600.0
    warmup: float = 1800.0
    points: int = 24
    dwell: float = 60.0
    step: float = 10.0
    angle0: float = 0.0

    def __post_init__(self) -> None:
        sp = tuple(float(v) for v in np.atleast_1d(np.asarray(self.setpoints, dtype=float)))
        if not sp:
            raise AccelcalError("give at least one plateau setpoint", parameter="setpoints")
        check_temperature(np.r_[sp, self.start], "setpoints and start")
        object.__setattr__(self, "setpoints", sp)
        if not (np.isfinite(self.step) and self.step > 0):
            raise AccelcalError(f"step {self.step} s must be positive", parameter="step")
        if not (np.isfinite(self.ramp_rate) and 1e-6 <= self.ramp_rate <= 1e6):
            raise AccelcalError(f"ramp rate {self.ramp_rate} degC/min must be from 1e-6 to 1e6 "
                                "(chambers ramp at 0.1-20 degC/min)", parameter="ramp_rate")
        for name in ("soak", "warmup", "dwell"):
            value = getattr(self, name)
            n = value / self.step
            if not (np.isfinite(n) and n >= (1 if name == "dwell" else 0)
                    and abs(n - round(n)) < 1e-9):
                raise AccelcalError(f"{name} {value} s must be a whole number (>= "
                                    f"{1 if name == 'dwell' else 0}) of steps of {self.step} s",
                                    parameter=name)
        if isinstance(self.points, bool) or not isinstance(self.points, int | np.integer) or \
                self.points < 1:
            raise AccelcalError(f"{self.points!r} tumble positions: give an integer >= 1",
                                parameter="points")
        # the steps the schedule will take, counted in floats before anything is rounded
        path = float(np.abs(np.diff(np.r_[self.start, sp])).sum())
        ramps = 60.0 * path / float(self.ramp_rate)
        steps = (float(self.warmup) + ramps + len(sp) * (
            float(self.soak) + float(self.points) * float(self.dwell))) / float(self.step)
        if not steps <= MAX_STEPS:
            raise AccelcalError(f"the programme takes {steps:.3g} steps of {self.step:g} s, more "
                                f"than {MAX_STEPS:g}; shorten it or take longer steps",
                                parameter="step")

    def schedule(self):
        """Per step: chamber setpoint path, phase, plateau, angle, hysteresis sign (arrays)."""
        h = self.step
        n_dwell = round(self.dwell / h)
        pieces, last, sign = [], self.start, 0
        angles = self.angle0 + np.arange(self.points) * 2.0 * np.pi / self.points
        # warm-up at the start temperature (phase 0, plateau -1)
        pieces.append((np.full(round(self.warmup / h), self.start), PHASES["warm-up"], -1,
                       self.angle0, 0, True))
        for j, sp in enumerate(self.setpoints):
            n_ramp = int(np.ceil(abs(sp - last) / (self.ramp_rate / 60.0) / h - 1e-9))
            sign = int(np.sign(sp - last)) or sign
            ramp = last + (sp - last) * np.arange(1, n_ramp + 1) / max(n_ramp, 1)
            pieces.append((ramp, -1, j, self.angle0, sign, False))  # not recorded
            pieces.append((np.full(round(self.soak / h), sp), PHASES["soak"], j, self.angle0,
                           sign, True))
            pieces.append((np.full(self.points * n_dwell, sp), PHASES["tumble"], j,
                           np.repeat(angles, n_dwell), sign, True))
            last = sp
        chamber = np.concatenate([[self.start]] + [p[0] for p in pieces])
        steps = chamber.size - 1
        check_memory(steps, 1, MEMORY_FACTOR, f"{steps} simulation steps", parameter="step")
        work.simulated("thermal", "the thermal programme", steps, parameter="step",
                       hint="give a longer step or fewer plateaus")

        def per_step(k):
            return np.concatenate([np.broadcast_to(p[k], p[0].shape) for p in pieces])

        return (chamber, per_step(1), per_step(2), per_step(3).astype(float), per_step(4),
                per_step(5).astype(bool))


def lag(chamber, tau: float, step: float, initial: float) -> np.ndarray:
    """The sensor temperature at each step: Eq. (2), exact for piecewise-linear air.

    Parameters
    ----------
    chamber : array_like, shape (n,)
        Air temperature at times ``0, step, ...``, degC.
    tau : float
        Thermal time constant of the sensor, s (0: no lag).
    step : float
        Sample interval, s.
    initial : float
        Sensor temperature at time 0, degC.

    Returns
    -------
    numpy.ndarray, shape (n,)
        The sensor temperature (``initial`` first), degC.

    References
    ----------
    .. [1] Franklin, Powell, Workman, sec. 6.3.2 (first-order hold).
    """
    from scipy.signal import lfilter

    u = np.asarray(chamber, dtype=float)
    if tau == 0:
        return u.copy()
    a = np.exp(-step / tau)
    b1 = 1.0 - (tau / step) * (-np.expm1(-step / tau))  # Eq. (2) [FOH]
    b0 = (tau / step) * (-np.expm1(-step / tau)) - a
    out = np.empty_like(u)
    out[0] = initial
    if u.size > 1:  # y[n] = a y[n-1] + b1 u[n] + b0 u[n-1] for n >= 1, from y[0] = initial
        out[1:] = lfilter([b1, b0], [1.0, -a], u[1:], zi=[a * initial + b0 * u[0]])[0]
    return out


def simulate(model: ErrorModel, programme: Programme | None = None, *, tau: float = 600.0,
             rotation_axis: str = "OA", noise: float = 2e-5, temperature_noise: float = 0.01,
             warmup_amplitude: float = 0.0, warmup_tau: float = 300.0,
             hysteresis: float = 0.0, hysteresis_scale: float = 0.0,
             rate_sensitivity: float = 0.0, seed=None) -> ThermalRecord:
    """A simulated thermal-chamber test of ``model`` (see the module docs).

    Parameters
    ----------
    model : ErrorModel
        The accelerometer, with its temperature terms (the truth).
    programme : Programme, optional
        Chamber programme and tumble; default :class:`Programme()`.
    tau : float
        Sensor thermal time constant, s.
    rotation_axis : {"OA", "PA"}
    noise : float
        Output noise SD per reading, output unit.
    temperature_noise : float
        Noise SD of the sensor's temperature reading, degC.
    warmup_amplitude, warmup_tau : float
        Bias transient after turn-on ``A exp(-t/tau_w)``: A in g, tau_w in s.
    hysteresis : float
        Bias difference between plateaus reached by heating and by cooling,
        g (+h/2 after heating, -h/2 after cooling, 0 before any ramp).
    hysteresis_scale : float
        Scale-factor difference, heating minus cooling, relative to K1 at T0
        (``K1(T) + s hs/2 K1``, s = +-1).
    rate_sensitivity : float
        Bias per rate of change of the sensor temperature, g per degC/min.
    seed : int or numpy.random.Generator, optional

    Returns
    -------
    ThermalRecord
        Metadata: the truth (``true_model``, ``tau_s`` and the other
        settings), ``noise_sd``, ``simulated`` and ``seed`` (an int seed).

    Raises
    ------
    AccelcalError
        For a bad setting (named), or outputs that overflow.
    """
    programme = programme or Programme()
    for name, value in (("tau", tau), ("noise", noise), ("temperature_noise", temperature_noise),
                        ("warmup_tau", warmup_tau)):
        if not (np.isfinite(value) and value >= 0):
            raise AccelcalError(f"{name} = {value} must be a finite value >= 0", parameter=name)
    for name, value in (("warmup_amplitude", warmup_amplitude), ("hysteresis", hysteresis),
                        ("hysteresis_scale", hysteresis_scale),
                        ("rate_sensitivity", rate_sensitivity)):
        if not (np.isfinite(value) and abs(value) < 1.0):
            raise AccelcalError(f"{name} = {value} must be finite and below 1 in magnitude",
                                parameter=name)
    rng = generator(seed)
    h = programme.step
    chamber, phase, plateau, angle, sign, kept = programme.schedule()
    sensor = lag(chamber, tau, h, programme.start)
    rate = (chamber - sensor) / tau if tau > 0 else np.gradient(chamber, h)  # Eq. (1) [Lag]
    t = np.arange(chamber.size) * h
    keep = np.flatnonzero(np.r_[False, kept])  # row k+1 is the end of step k
    ts, temp, dtdt = t[keep], sensor[keep], rate[keep] * 60.0
    s = sign[keep - 1]
    a_i, a_o, a_p = specific_force(angle[keep - 1], rotation_axis)
    k1 = model.terms_at(temp)["K1"] + 0.5 * s * hysteresis_scale * model.K1  # relative to K1(T0)
    extra = 0.5 * s * hysteresis + rate_sensitivity * dtdt
    if warmup_tau > 0:
        with np.errstate(over="ignore"):  # a tiny warmup_tau: exp(-inf) = 0, exactly right
            extra = extra + warmup_amplitude * np.exp(-ts / warmup_tau)
    with np.errstate(over="ignore", invalid="ignore"):
        out = k1 * (model.output_g(a_i, a_o, a_p, temperature=temp) + extra)
        out = out + rng.normal(0.0, noise, size=out.size)
    if not np.all(np.abs(out) <= 1e9):
        raise AccelcalError("the simulated outputs overflow: the model's coefficients are "
                            "beyond any accelerometer")
    meta = {"simulated": True, "noise_sd": float(noise), "true_model": model.to_dict(),
            "tau_s": float(tau), "temperature_noise_degC": float(temperature_noise),
            "warmup_amplitude_g": float(warmup_amplitude), "warmup_tau_s": float(warmup_tau),
            "hysteresis_g": float(hysteresis), "hysteresis_scale": float(hysteresis_scale),
            "rate_sensitivity_g_per_degC_min": float(rate_sensitivity),
            "ramp_rate_degC_min": programme.ramp_rate, "soak_s": programme.soak}
    if isinstance(seed, int | np.integer):
        meta["seed"] = int(seed)
    return ThermalRecord(
        t=ts, phase=phase[keep - 1], plateau=plateau[keep - 1], angle_rad=angle[keep - 1],
        output=out, temperature=temp + rng.normal(0.0, temperature_noise, size=temp.size),
        rotation_axis=rotation_axis, output_unit=model.output_unit,
        setpoints=programme.setpoints, start=programme.start, chamber=chamber[keep],
        metadata=meta)
