"""Precision centrifuge rig (IEEE 836): a sensor on a horizontal arm, with the rig's errors.

The sensor's reference point is at nominal radius R0 on an arm turning at
rate Omega about a vertical axis; the sensor sits in one of the positions of
:data:`accelcal.physics.centrifuge.POSITIONS` (or any orientation
by three angles). Each reading is the output averaged over one revolution,
computed by quadrature over the arm's phase (:data:`QUADRATURE` points,
time-weighted: exact for the trigonometric polynomials the model makes of
tilt and ripple), with the errors:

* radius error ``dR/R0`` and arm stretch ``R = R0 (1 + dR/R0 + s Omega^2)``;
* rate error (the true rate is the recorded one times ``1 + e``) and a
  once-per-revolution ripple ``Omega(phi) = Omega0 (1 + rho cos(phi - phi_r))``
  with its tangential acceleration ``R dOmega/dt``;
* misalignment of the sensor on the arm (three small angles about its own
  IA, OA, PA, per position);
* spin-axis tilt (the vertical turns once per revolution in the arm frame);
* proof-mass offset ``d`` along IA (the proof mass sits at ``R0 - d (i . r)``);

plus Gaussian output noise per reading. Before each step, optional spin-up
readings (rates ramping from the previous step's) are recorded and marked.

References
----------
.. [IEEE836] IEEE Std 836-2009, IEEE Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
.. [DOMAIN] accelcal domain notes, section 9.
"""

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.centrifuge import (
    MAX_LEVEL,
    MAX_OUTPUT,
    MAX_RADIUS,
    MAX_RATE,
    MIN_RADIUS,
    CentrifugeRecord,
    check_positions,
    check_survey,
)
from accelcal.model import ErrorModel
from accelcal.physics.centrifuge import (
    misaligned,
    position_matrix,
    specific_force,
)
from accelcal.resources import check_memory, generator
from accelcal.units import STANDARD_GRAVITY

QUADRATURE = 64
"""Phase points per revolution: the time-weighted mean of a trigonometric polynomial of
degree < 64 is exact; tilt, ripple and the model's fourth power stay far below that."""

MAX_SMALL = 0.1
"""Largest radius error, rate error, ripple (relative), misalignment and tilt (rad) a rig
takes: the reductions linearise in them; beyond 10 % it is not a precision centrifuge."""


@dataclass(frozen=True)
class CentrifugeRig:
    """A horizontal centrifuge and its errors.

    Parameters
    ----------
    radius : float
        Nominal radius R0 of the sensor's reference point, m.
    radius_error : float
        True relative radius error dR/R0.
    arm_stretch : float
        s in ``R = R0 (1 + dR/R0 + s Omega^2)``, s^2.
    rate_error : float
        True rate = recorded rate x (1 + rate_error).
    ripple, ripple_phase : float
        Once-per-revolution rate ripple: relative amplitude and phase (rad).
    tilt, tilt_azimuth : float
        Spin-axis tilt from the vertical and its azimuth in the rig frame, rad.
    misalignment : mapping
        Position name -> three angles (rad) about the sensor's IA, OA, PA.
    proof_mass_offset : float
        Offset of the proof mass from the reference point along IA, m.
    gravity : float
        Local gravity, m/s^2.
    """

    radius: float = 1.0
    radius_error: float = 0.0
    arm_stretch: float = 0.0
    rate_error: float = 0.0
    ripple: float = 0.0
    ripple_phase: float = 0.0
    tilt: float = 0.0
    tilt_azimuth: float = 0.0
    misalignment: Mapping = field(default_factory=dict)
    proof_mass_offset: float = 0.0
    gravity: float = STANDARD_GRAVITY

    def __post_init__(self) -> None:
        for name in ("radius", "radius_error", "arm_stretch", "rate_error", "ripple",
                     "ripple_phase", "tilt", "tilt_azimuth", "proof_mass_offset", "gravity"):
            value = getattr(self, name)
            if isinstance(value, bool) or not np.isfinite(float(value)):
                raise AccelcalError(f"{value!r} must be a finite number", parameter=name)
            object.__setattr__(self, name, float(value))
        if not MIN_RADIUS <= self.radius <= MAX_RADIUS:
            raise AccelcalError(f"{self.radius:g} m is not an arm radius ({MIN_RADIUS:g} to "
                                f"{MAX_RADIUS:g} m)", parameter="radius")
        if not 9.7 <= self.gravity <= 9.9:
            raise AccelcalError(f"{self.gravity:g} m/s^2 is not a local gravity (9.7-9.9)",
                                parameter="gravity")
        for name in ("radius_error", "rate_error", "ripple", "tilt"):
            if abs(getattr(self, name)) > MAX_SMALL:
                raise AccelcalError(f"{getattr(self, name):g} is beyond {MAX_SMALL:g}: not a "
                                    "precision centrifuge's error", parameter=name)
        if abs(self.proof_mass_offset) > 0.1 * self.radius:
            raise AccelcalError(f"{self.proof_mass_offset:g} m is beyond a tenth of the radius",
                                parameter="proof_mass_offset")
        clean = {}
        for key, value in dict(self.misalignment).items():
            v = np.asarray(value, dtype=float).reshape(-1)
            if v.size != 3 or not np.isfinite(v).all() or np.abs(v).max() > MAX_SMALL:
                raise AccelcalError(f"misalignment of {key!r} must be three finite angles "
                                    f"within +-{MAX_SMALL} rad", parameter="misalignment")
            clean[str(key)] = tuple(float(x) for x in v)
        object.__setattr__(self, "misalignment", clean)

    def to_dict(self) -> dict:
        """JSON-ready description (the truth a simulated record keeps)."""
        d = asdict(self)
        d["misalignment"] = {k: list(v) for k, v in self.misalignment.items()}
        return d

    def orientation(self, name: str, c) -> np.ndarray:
        """The true orientation of position ``name`` (nominal ``c``, misaligned)."""
        return misaligned(np.asarray(c, dtype=float), self.misalignment.get(name, (0, 0, 0)))

    def revolution_mean(self, model: ErrorModel, c, rate) -> np.ndarray:
        """Output (g) averaged over one revolution at recorded rates ``rate``, shape (n,).

        Time-weighted quadrature over the arm phase: ``dt = dphi / Omega(phi)``.
        ``c`` has shape ``(n, 3, 3)`` (true orientations), ``rate`` ``(n,)``.
        """
        phi = 2 * np.pi * np.arange(QUADRATURE) / QUADRATURE
        w_true = np.asarray(rate, dtype=float)[:, None] * (1.0 + self.rate_error)
        shape = 1.0 + self.ripple * np.cos(phi - self.ripple_phase)
        omega0 = w_true * np.mean(1.0 / shape)  # the revolution's mean rate is w_true
        omega = omega0 * shape  # (n, Q)
        omega_dot = -omega0 * self.ripple * np.sin(phi - self.ripple_phase) * omega
        st, ct = np.sin(self.tilt), np.cos(self.tilt)
        up = np.stack(np.broadcast_arrays(-st * np.cos(phi - self.tilt_azimuth),
                                          -st * np.sin(phi - self.tilt_azimuth), ct), axis=-1)
        a = specific_force(np.asarray(c)[:, None], omega, self.radius, gravity=self.gravity,
                           radius_error=self.radius_error, arm_stretch=self.arm_stretch,
                           proof_mass_offset=self.proof_mass_offset, rate_dot=omega_dot, up=up)
        u = model.output_g(*a)
        w = 1.0 / omega if np.any(w_true) else np.ones_like(omega)
        return np.sum(u * w, axis=-1) / np.sum(w, axis=-1)

    def overload(self, vectors, misalignment=(0.0, 0.0, 0.0)) -> np.ndarray:
        """The specific force a sensor feels when the rig is set for overload ``vectors``.

        Each nominal overload ``b`` (sensor axes, g) is produced by the rig at
        level ``|b|`` with the arm's inward radial along ``b`` and the vertical
        along the sensor axis most nearly perpendicular to it (PA, then OA,
        then IA); the result is the revolution mean of the true specific
        force (radius error, stretch, rate error, ripple, proof-mass offset,
        ``misalignment``, gravity on the vertical), shape ``(P, 3)``.

        References
        ----------
        .. [1] Guan2021, sec. 2 (the overload comes from a centrifuge); DOMAIN
           section 9.
        """
        b = np.asarray(vectors, dtype=float).reshape(-1, 3)
        level = np.linalg.norm(b, axis=1)
        out = np.empty_like(b)
        for k, (vec, lev) in enumerate(zip(b, level, strict=True)):
            r = vec / lev if lev > 0 else np.array([1.0, 0.0, 0.0])
            e = next(np.eye(3)[j] for j in (2, 1, 0) if abs(r[j]) < 0.9)
            z = e - (e @ r) * r
            z = z / np.linalg.norm(z)
            c = misaligned(np.column_stack([r, np.cross(z, r), z]), misalignment)
            rate = np.sqrt(lev * STANDARD_GRAVITY / self.radius)
            out[k] = [self._mean_force(c, rate, j) for j in range(3)]
        return out

    def _mean_force(self, c, rate, axis: int) -> float:
        return float(self.revolution_mean(_AxisModel(axis), c[None], np.array([rate]))[0])


class _AxisModel:
    """A stand-in for a model whose output is one component of the specific force."""

    def __init__(self, axis: int) -> None:
        self.axis = axis

    def output_g(self, a_i, a_o, a_p):
        return (a_i, a_o, a_p)[self.axis]


def positions_of(positions: Sequence) -> tuple[tuple[dict, ...], np.ndarray]:
    """Validated position specs (names or dicts) and their nominal orientation matrices."""
    specs = [{"name": p} if isinstance(p, str) else dict(p) for p in positions]
    specs = list(check_positions(specs, "positions", "positions"))
    mats = np.stack([position_matrix(s) for s in specs])
    return tuple(specs), mats


def simulate(model: ErrorModel, positions: Sequence, levels, *, rig: CentrifugeRig | None = None,
             readings: int = 1, spinup: int = 0, noise: float | None = None, seed=None,
             survey: Mapping | None = None) -> CentrifugeRecord:
    """Simulate a centrifuge test: every position at every level.

    Parameters
    ----------
    model : ErrorModel
        The accelerometer.
    positions : sequence
        Position names (:data:`~accelcal.physics.centrifuge.POSITIONS`)
        or ``{"name": ..., "angles_deg": [yaw, pitch, roll]}``.
    levels : array_like
        Nominal levels, g (> 0); the recorded rate is ``sqrt(level g_n / R0)``.
    rig : CentrifugeRig, optional
        The rig and its errors (default: 1 m, no errors).
    readings : int
        Steady readings per step (each one revolution).
    spinup : int
        Spin-up readings before each step (marked, rate ramping).
    noise : float, optional
        Noise SD of one reading, output unit (default ``sigma |K1|``).
    seed : int or numpy.random.Generator, optional
    survey : mapping, optional
        Rig errors as a survey reports them (written to the record).

    Returns
    -------
    CentrifugeRecord
        Steps ordered by position then level; metadata ``simulation``:
        ``rig``, ``true_model``, ``noise_sd``, ``seed``; ``simulated: true``.

    References
    ----------
    .. [1] IEEE836; DOMAIN section 9.
    """
    rig = CentrifugeRig() if rig is None else rig
    specs, mats = positions_of(positions)
    lev = np.asarray(levels, dtype=float).reshape(-1)
    if lev.size == 0 or not np.isfinite(lev).all() or (lev <= 0).any() or \
            (lev > MAX_LEVEL).any():
        raise AccelcalError(f"must be levels in g, 0 < level <= {MAX_LEVEL:g}",
                            parameter="levels")
    for name, value in (("readings", readings), ("spinup", spinup)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or \
                value < (name == "readings"):
            raise AccelcalError(f"{value!r} must be a whole number >= "
                                f"{int(name == 'readings')}", parameter=name)
    noise = model.sigma * abs(model.K1) if noise is None else float(noise)
    if not (np.isfinite(noise) and 0 <= noise <= MAX_OUTPUT / 100):
        raise AccelcalError(f"{noise} must be a finite SD >= 0 (output unit)", parameter="noise")
    n_steps = len(specs) * lev.size
    per_step = readings + spinup
    check_memory(float(n_steps) * per_step, 2 * 64, 4,
                 f"{n_steps} steps of {per_step} readings", parameter="readings")
    work.simulated("centrifuge", f"{n_steps} steps of {per_step} readings",
                   float(n_steps) * per_step, parameter="readings",
                   hint="give fewer readings, spin-up readings or levels")
    rng = generator(seed)
    pos = np.repeat(np.arange(len(specs)), lev.size)
    level = np.tile(lev, len(specs))
    rate = np.sqrt(level * STANDARD_GRAVITY / rig.radius)
    if rate.max() > MAX_RATE:
        raise AccelcalError(f"{lev.max():g} g at {rig.radius:g} m needs {rate.max():.4g} rad/s, "
                            f"beyond the {MAX_RATE:g} rad/s a record holds", parameter="levels")
    prev = np.where(np.arange(n_steps) % lev.size == 0, 0.0, np.roll(rate, 1))
    frac = np.arange(1, spinup + 1) / (spinup + 1)
    ramp = prev[:, None] + (rate - prev)[:, None] * frac  # (S, spinup)
    rates = np.concatenate([ramp, np.repeat(rate[:, None], readings, axis=1)], axis=1)
    true_c = np.stack([rig.orientation(specs[p]["name"], mats[p]) for p in range(len(specs))])
    c = np.repeat(true_c[pos], per_step, axis=0)
    with np.errstate(over="ignore", invalid="ignore"):
        out = model.K1 * rig.revolution_mean(model, c, rates.reshape(-1))
    out = out + (rng.normal(0.0, noise, out.shape) if noise > 0 else 0.0)
    if not np.abs(out).max() <= MAX_OUTPUT:
        raise AccelcalError("the simulated outputs overflow the record's limit: the model's "
                            "coefficients or the levels are beyond any accelerometer")
    flags = np.concatenate([np.ones((n_steps, spinup)), np.zeros((n_steps, readings))], axis=1)
    meta = {"simulated": True, "simulation": {
        "rig": rig.to_dict(), "true_model": model.terms(), "noise_sd": noise,
        **({"seed": int(seed)} if isinstance(seed, int | np.integer) else {})}}
    return CentrifugeRecord(
        step=np.repeat(np.arange(n_steps), per_step), position=np.repeat(pos, per_step),
        level=np.repeat(level, per_step), rate=rates.reshape(-1), output=out,
        spinup=flags.reshape(-1), positions=specs, radius_m=rig.radius,
        output_unit=model.output_unit,
        survey=check_survey(dict(survey or {}), "survey"), metadata=meta)
