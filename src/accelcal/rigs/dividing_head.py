"""Indexing (dividing) head rig: accelerometers mounted around a head turning in gravity.

The head's axis is horizontal and along each accelerometer's pendulum axis
(PA). At nominal head angle ``alpha_j`` an accelerometer mounted at phase
``phi_k`` with misalignment ``eta_k`` feels ::

    beta_kj = alpha_j + phi_k                      (nominal sensor angle)
    a_i = sin(beta_kj + d_alpha_j + eta_k),  a_o = cos(beta_kj + d_alpha_j + eta_k),  a_p = 0

where ``d_alpha_j`` is the head's angular position error at that position.
Outputs come from each sensor's :class:`~accelcal.model.ErrorModel`
(exactly, no linearisation), plus Gaussian noise.

Arrays follow the project convention: leading axes are trials (and
repeats, sensors), the last axis is positions. One call simulates any
number of trials at once.

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eqs. (1)-(5), (14).
.. [DOMAIN] accelcal domain notes, section 4.
"""

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.dividing_head import MAX_ANGLE_ERROR_RAD, MAX_OUTPUT, check_positions
from accelcal.model import ErrorModel
from accelcal.resources import check_memory, generator
from accelcal.units import DEG

DEFAULT_MOUNTS_DEG = (0.0, 90.0, 180.0, 270.0)
"""Mount phases of Dong2014's four accelerometers, eqs. (1)-(4), degrees."""

DONG2014_TABLE1 = (
    {"K_F": -8.336e-4, "K_I": 1.2993698, "K_O": -1.226e-5, "K_IO": -2.849e-5, "K_II": 3.91e-6},
    {"K_F": -4.133e-3, "K_I": 1.3245304, "K_O": -7.29e-6, "K_IO": 7.93e-6, "K_II": 1.573e-5},
    {"K_F": -9.2e-4, "K_I": 1.297999, "K_O": -1.173e-5, "K_IO": -1.905e-5, "K_II": 7.41e-6},
    {"K_F": -1.2999e-3, "K_I": 1.29999, "K_O": -8.578e-6, "K_IO": -9.327e-6, "K_II": 2.48e-6},
)
"""Dong2014 Table 1, column B_z (first harmonic known): the four sensors'
coefficients in volts (K_I in V/g). Used as a realistic default truth."""

DONG2014_FIRST_HARMONIC = (1.50e-5, -1.9e-6)
"""Dong2014 section 3: the head's measured first harmonic (d1c, d1s), rad."""

MIN_POSITIONS = 6
"""Fewest positions of a rig: every reduction fits 5 coefficients per sensor and needs a
degree of freedom for the noise (``single``: 6; ``four``: 12; ``joint``: depends on K)."""

MAX_NOISE = MAX_OUTPUT / 100
"""Largest output noise standard deviation of a rig, in the output unit: the
simulated readings stay within the +-MAX_OUTPUT a record file may hold
(:data:`accelcal.io.formats.dividing_head.MAX_OUTPUT`), and no number in the
simulation or a study can overflow."""

MAX_MOUNT_RAD = 2 * np.pi
"""Largest mount phase magnitude, rad (360 deg): a phase is an angle on the head;
a huge one leaves no significant digits to its sine and cosine."""

DONG2014_NOISE_V = 2.8e-6
"""Dong2014 Table 1, column U: residual standard deviation of sensor 1, V."""


def dong2014_models(count: int = 4) -> tuple[ErrorModel, ...]:
    """Models built from Dong2014 Table 1 (B_z), repeated cyclically for ``count`` sensors.

    References
    ----------
    .. [1] Dong2014, Table 1.
    """
    if count < 1:
        raise AccelcalError(f"need at least one sensor, got {count}")
    return tuple(ErrorModel.from_dong2014(**DONG2014_TABLE1[k % 4]) for k in range(count))


@dataclass(frozen=True)
class AngleErrorProfile:
    """The head's angular position error as a function of the nominal angle.

    Build it with :meth:`uniform`, :meth:`harmonics` or :meth:`values`.

    Parameters
    ----------
    kind : {"uniform", "harmonics", "values", "none"}
        Uniform random within +-``half_width`` (a new draw per trial),
        a Fourier series, or a user array (one value per position).
    half_width : float
        Half width of the uniform distribution, rad.
    terms : mapping
        ``{(m, "c" | "s"): amplitude_rad}`` for harmonics m >= 0
        (``(0, "c")`` is the mean).
    given : numpy.ndarray
        The user's values, rad, one per position.
    """

    kind: str = "none"
    half_width: float = 0.0
    terms: Mapping = field(default_factory=dict)
    given: np.ndarray | None = None

    @classmethod
    def uniform(cls, half_width_rad: float) -> "AngleErrorProfile":
        """Independent uniform errors in [-h, h] rad at each position, drawn per trial."""
        h = float(half_width_rad)
        if not np.isfinite(h) or h < 0:
            raise AccelcalError(f"uniform angle error half width must be finite and >= 0, got {h}")
        _check_angle(h, "uniform angle error half width", "angle_error")
        return cls(kind="uniform", half_width=h)

    @classmethod
    def harmonics(cls, terms: Mapping) -> "AngleErrorProfile":
        """A Fourier series ``sum a_mc cos(m alpha) + a_ms sin(m alpha)``, rad."""
        clean = {}
        for key, value in dict(terms).items():
            m, cs = key
            if int(m) != m or m < 0 or cs not in ("c", "s") or (m == 0 and cs == "s"):
                raise AccelcalError(
                    f"angle-error harmonic {key!r} is not (m >= 0, 'c' or 's'); e.g. (2, 'c')"
                )
            v = float(value)
            if not np.isfinite(v):
                raise AccelcalError(f"angle-error harmonic {key!r} amplitude {v} is not finite")
            clean[(int(m), cs)] = v
        _check_angle(sum(abs(v) for v in clean.values()),
                     "angle-error harmonics (sum of the amplitudes)", "angle_error")
        return cls(kind="harmonics", terms=clean)

    @classmethod
    def values(cls, values_rad) -> "AngleErrorProfile":
        """The user's angle errors, rad, one per position (same for every trial)."""
        arr = np.asarray(values_rad, dtype=float).reshape(-1)
        if not np.isfinite(arr).all():
            raise AccelcalError("angle-error values contain NaN or inf; give finite radians")
        if arr.size:
            _check_angle(float(np.abs(arr).max()), "angle-error values", "angle_error")
        return cls(kind="values", given=arr)

    def draw(self, alpha: np.ndarray, trials: int, rng: np.random.Generator | None) -> np.ndarray:
        """Angle errors, rad, shape ``(trials, n)`` at nominal angles ``alpha`` (rad)."""
        n = alpha.shape[-1]
        if self.kind == "uniform":
            if rng is None and self.half_width > 0:
                raise AccelcalError("a uniform random angle error needs a seed or Generator")
            if self.half_width == 0:
                return np.zeros((trials, n))
            return rng.uniform(-self.half_width, self.half_width, size=(trials, n))
        if self.kind == "harmonics":
            d = np.zeros(n)
            for (m, cs), a in self.terms.items():
                wave = np.cos(m * alpha) if cs == "c" else np.sin(m * alpha)
                d = d + a * wave  # Eq. (14) [Dong2014]
            return np.broadcast_to(d, (trials, n)).copy()
        if self.kind == "values":
            if self.given.size != n:
                raise AccelcalError(
                    f"{self.given.size} angle-error values given for {n} positions; "
                    "give one per position"
                )
            return np.broadcast_to(self.given, (trials, n)).copy()
        return np.zeros((trials, n))


@dataclass(frozen=True)
class DividingHeadRig:
    """Accelerometers on an indexing head: positions, mounts, models, errors, noise.

    Parameters
    ----------
    positions : array_like
        Nominal head angles alpha_j, rad (distinct modulo 2 pi).
    models : sequence of ErrorModel
        One model per sensor (outputs in the models' unit, volts in Dong2014).
    mounts : array_like, optional
        Mount phase phi_k of each sensor, rad, within +-2 pi
        (:data:`MAX_MOUNT_RAD`). Default 0, 90, 180, 270 deg (cycled for
        more sensors), as Dong2014 eqs. (1)-(4).
    eta : array_like, optional
        Mounting misalignment eta_k of each sensor, rad (default 0).
    angle_error : AngleErrorProfile, optional
        The head's angular position error profile (default none).
    first_harmonic : (float, float)
        First harmonic (d1c, d1s) of the head error added to the profile, rad.
    noise : float or array_like, optional
        Output noise standard deviation per sensor, in the output unit, at
        most :data:`MAX_NOISE`; by default each model's ``sigma * K1``.
    repeats : int
        Readings per position (the head error is the same at each repeat).

    References
    ----------
    .. [1] Dong2014, eqs. (1)-(5), (14).
    """

    positions: np.ndarray
    models: tuple
    mounts: np.ndarray | None = None
    eta: np.ndarray | None = None
    angle_error: AngleErrorProfile = field(default_factory=AngleErrorProfile)
    first_harmonic: tuple[float, float] = (0.0, 0.0)
    noise: object = None
    repeats: int = 1

    def __post_init__(self) -> None:
        alpha = np.asarray(self.positions, dtype=float).reshape(-1)
        check_positions(alpha)
        if alpha.size < MIN_POSITIONS:
            raise AccelcalError(
                f"{alpha.size} positions: every reduction fits 5 coefficients per sensor and "
                f"needs a degree of freedom; give at least {MIN_POSITIONS} (method four: 12)",
                parameter="positions")
        models = tuple(self.models)
        if not models or not all(isinstance(m, ErrorModel) for m in models):
            raise AccelcalError("models must be a non-empty sequence of ErrorModel, one per sensor")
        k = len(models)
        mounts = (
            np.array([DEFAULT_MOUNTS_DEG[i % 4] for i in range(k)]) * DEG
            if self.mounts is None
            else np.asarray(self.mounts, dtype=float).reshape(-1)
        )
        if mounts.size != k:
            raise AccelcalError(f"{mounts.size} mount phases given for {k} sensors; give one each")
        if not (np.abs(mounts) <= MAX_MOUNT_RAD).all():  # NaN too
            raise AccelcalError(
                f"mount phases must be angles within +-360 deg ({MAX_MOUNT_RAD:.4g} rad), got "
                f"{np.degrees(mounts[~(np.abs(mounts) <= MAX_MOUNT_RAD)][0]):.3g} deg",
                parameter="mounts")
        _check_distinct(mounts)
        eta = np.zeros(k) if self.eta is None else np.asarray(self.eta, dtype=float).reshape(-1)
        if eta.size != k:
            raise AccelcalError(f"{eta.size} misalignments given for {k} sensors; give one each")
        if self.noise is None:
            noise = np.array([m.sigma * abs(m.K1) for m in models])
        else:
            noise = np.broadcast_to(np.asarray(self.noise, dtype=float), (k,)).copy()
        if not (np.isfinite(noise).all() and (noise >= 0).all()):
            raise AccelcalError(f"standard deviations must be finite and >= 0, got {noise}",
                                parameter="noise")
        if (noise > MAX_NOISE).any():
            raise AccelcalError(
                f"standard deviation {noise.max():.3g} is beyond {MAX_NOISE:g} (output unit): "
                "the readings would not be readings; check the value and its unit",
                parameter="noise")
        if int(self.repeats) != self.repeats or self.repeats < 1:
            raise AccelcalError(f"must be an integer >= 1, got {self.repeats}",
                                parameter="repeats")
        h1 = tuple(float(v) for v in self.first_harmonic)
        if len(h1) != 2 or not np.isfinite(h1).all():
            raise AccelcalError(
                f"first_harmonic must be two finite numbers (C, S) in rad, got {h1}"
            )
        _check_angle(float(np.hypot(*h1)), "first harmonic amplitude", "first_harmonic")
        if eta.size and np.isfinite(eta).all():
            _check_angle(float(np.abs(eta).max()), "mounting misalignment", "eta")
        for name, value in (("positions", alpha), ("mounts", mounts), ("eta", eta),
                            ("noise", noise)):
            if not np.isfinite(value).all():
                raise AccelcalError(f"{name} contain NaN or inf")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "models", models)
        object.__setattr__(self, "first_harmonic", h1)
        object.__setattr__(self, "repeats", int(self.repeats))

    @classmethod
    def uniform(cls, n: int, models: Sequence[ErrorModel], **kwargs) -> "DividingHeadRig":
        """A rig with ``n`` equally spaced positions ``2 pi j / n``."""
        if isinstance(n, bool) or int(n) != n or n < MIN_POSITIONS:
            raise AccelcalError(
                f"must be an integer >= {MIN_POSITIONS} (every reduction fits 5 coefficients "
                f"per sensor and needs a degree of freedom; method four: 12), got {n}",
                parameter="positions")
        k = len(models)
        repeats = kwargs.get("repeats", 1)
        repeats = repeats if isinstance(repeats, int | np.integer) and repeats > 0 else 1
        require_simulation_memory(int(n), k, repeats)
        return cls(positions=uniform_positions(int(n)), models=tuple(models), **kwargs)

    @property
    def n_sensors(self) -> int:
        """Number of sensors K."""
        return len(self.models)

    def sensor_angles(self) -> np.ndarray:
        """Nominal sensor angles beta_kj = alpha_j + phi_k, rad, shape ``(K, n)``."""
        return self.positions[None, :] + self.mounts[:, None]

    def angle_errors(self, trials: int, rng: np.random.Generator | None) -> np.ndarray:
        """Head angle errors d_alpha, rad, shape ``(trials, n)``: profile plus first harmonic."""
        d = self.angle_error.draw(self.positions, trials, rng)
        c, s = self.first_harmonic
        return d + c * np.cos(self.positions) + s * np.sin(self.positions)

    def outputs(self, d_alpha: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """Sensor outputs for given head errors.

        Parameters
        ----------
        d_alpha : numpy.ndarray
            Head angle errors, rad, shape ``(..., n)``.
        rng : numpy.random.Generator, optional
            Adds the rig's noise when given.

        Returns
        -------
        numpy.ndarray
            Outputs in the models' unit, shape ``(..., repeats, K, n)``.

        References
        ----------
        .. [1] Dong2014, eqs. (1)-(5); exact (not linearised).
        """
        d = np.asarray(d_alpha, dtype=float)[..., None, None, :]
        gamma = self.sensor_angles() + self.eta[:, None] + d  # Eqs. (1)-(4) [Dong2014]
        gamma = np.broadcast_to(gamma, (*gamma.shape[:-3], self.repeats, *gamma.shape[-2:]))
        out = np.empty(gamma.shape)
        for k, model in enumerate(self.models):
            g = gamma[..., k, :]
            out[..., k, :] = model.output(np.sin(g), np.cos(g), 0.0)  # Eq. (5) [Dong2014]
        if rng is not None and (self.noise > 0).any():
            out = out + rng.standard_normal(out.shape) * self.noise[:, None]
        return out


@dataclass(frozen=True)
class SimulatedRun:
    """What :func:`simulate` produced, with the truth kept for checks and metadata.

    Attributes
    ----------
    rig : DividingHeadRig
        The rig simulated.
    outputs : numpy.ndarray
        Outputs, shape ``(trials, repeats, K, n)`` (``(repeats, K, n)`` for a
        single run).
    d_alpha : numpy.ndarray
        Applied head angle errors, rad, shape ``(trials, n)`` (``(n,)``).
    """

    rig: DividingHeadRig
    outputs: np.ndarray
    d_alpha: np.ndarray


def simulate(rig: DividingHeadRig, seed=None, *, trials: int | None = None) -> SimulatedRun:
    """Simulate readings on the indexing head.

    Parameters
    ----------
    rig : DividingHeadRig
        The rig.
    seed : int or numpy.random.Generator, optional
        Randomness for the angle errors and the noise (an integer >= 0).
        Without it the run is noise-free and a random angle-error profile
        is refused.
    trials : int, optional
        Number of independent runs (each with its own angle-error draw and
        noise) on a leading axis; ``None`` for one run without that axis.

    Returns
    -------
    SimulatedRun
    """
    rng = None if seed is None else generator(seed)
    t = 1 if trials is None else int(trials)
    if t < 1:
        raise AccelcalError(f"trials must be >= 1, got {trials}")
    require_simulation_memory(rig.positions.size, rig.n_sensors, rig.repeats, trials=t)
    if trials is None:  # a study's trials are estimated by the study
        work.simulated("dividing-head", f"{rig.positions.size} positions x {rig.n_sensors} "
                       f"sensors x {rig.repeats} repeat(s)",
                       float(rig.positions.size) * rig.n_sensors * rig.repeats,
                       parameter="positions", hint="give fewer positions or repeats")
    d = rig.angle_errors(t, rng)
    out = rig.outputs(d, rng)
    if trials is None:
        return SimulatedRun(rig, out[0], d[0])
    return SimulatedRun(rig, out, d)


def uniform_positions(n: int, start: float = 0.0) -> np.ndarray:
    """``n`` equally spaced nominal angles ``start + 2 pi j / n``, rad."""
    return start + 2.0 * np.pi * np.arange(n) / n


SIMULATION_ARRAYS = 8
"""Arrays of the readings' size a simulation holds at its peak: the sensor angles, their
sines and cosines, the outputs, the noise and their sum, plus the columns written."""


def require_simulation_memory(n: int, k: int, repeats: int = 1, *, trials: int = 1) -> None:
    """Refuse a simulation of ``trials x repeats x k x n`` readings that cannot fit in memory.

    :func:`accelcal.resources.check_memory` with
    :data:`SIMULATION_ARRAYS` arrays of the readings' size.
    """
    check_memory(float(trials) * repeats * n, k, SIMULATION_ARRAYS,
                 f"simulating {n} positions x {k} sensors x {repeats} repeat(s)"
                 + (f" x {trials} trials" if trials > 1 else ""), parameter="positions",
                 hint="give fewer positions")


def _check_angle(value: float, what: str, parameter: str | None = None) -> None:
    """Refuse a head angle error beyond :data:`MAX_ANGLE_ERROR_RAD` (1 deg)."""
    if not value <= MAX_ANGLE_ERROR_RAD:
        raise AccelcalError(
            f"{what} {value:.3g} rad is beyond 1 deg ({MAX_ANGLE_ERROR_RAD:.4g} rad): not an "
            "indexing head's error (a few arcsec); check the value and its unit",
            parameter=parameter)


def _check_distinct(mounts: np.ndarray) -> None:
    """Refuse two sensors at the same mount phase (modulo 360 deg)."""
    if mounts.size < 2 or not np.isfinite(mounts).all():
        return
    wrapped = np.sort(np.mod(mounts, 2 * np.pi))
    gaps = np.diff(np.concatenate([wrapped, wrapped[:1] + 2 * np.pi]))
    if gaps.min() < 1e-9:
        same = np.degrees(wrapped[int(np.argmin(gaps))])
        raise AccelcalError(
            f"two sensors are mounted at the same phase ({same:.6g} deg): sensors at the same "
            "phase see the head error alike and cannot separate it; "
            "give distinct phases, e.g. 0,90,180,270", parameter="mounts")
