"""Triad rig: a time series of an accelerometer triad turned through static positions.

The recording starts with a still period at the first position (Tedaldi's
initialisation interval), which is that position's static interval
together with its dwell; each further position is reached by a smooth
rotation (a quintic-profile rotation about the axis taking one gravity
direction to the next, lasting ``motion`` seconds) and held for ``dwell``
seconds. During a motion the sensor, at ``lever_arm`` from the pivot, feels
the kinematic acceleration ``alpha x r + omega x (omega x r)`` besides gravity,
so motion shows in the outputs' variance as it does on a hand-turned cube.
A position that repeats the previous direction gets an out-and-back tilt of
20 deg. The outputs are the calibration's readings of the specific force
(:meth:`accelcal.methods.triad.model.TriadCalibration.readings`) plus white
Gaussian noise of ``noise_sd`` (input unit) per sample and axis.

Everything is in the fixture frame (the calibration's reference frame when
it holds a rotation, else its body frame): the positions' ``up`` vectors
are then exactly what a known-orientation calibration takes.

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, sec. IV
   (still initialisation, static intervals between motions).
"""

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.triad import MAX_VALUE, TriadRecord
from accelcal.resources import check_memory, generator

MEMORY_FACTOR = 20
"""Arrays of (samples x 3) float64 held at the peak: directions, rates, specific force,
readings, noise and the record (about 14 measured); 20 leaves a margin."""

WIGGLE = np.radians(20.0)
"""Tilt of the out-and-back motion between two positions with the same direction."""

MAX_SAMPLES = 50_000_000 // 4
"""Most samples of a simulated recording (a record holds 5e7 values, 4 columns)."""


def random_directions(n: int, rng) -> np.ndarray:
    """``n`` directions uniform on the sphere, shape (n, 3)."""
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def six_positions() -> np.ndarray:
    """The six-position (Ferraris) set: x, y, z up then down... in imucal's order."""
    return np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)


def _labels(up: np.ndarray) -> list[str]:
    """The labels imucal uses (x_p ... z_a) for axis-aligned unique directions, else P1..Pn."""
    names = {(0, 1): "x_p", (0, -1): "x_a", (1, 1): "y_p", (1, -1): "y_a", (2, 1): "z_p",
             (2, -1): "z_a"}
    out = []
    for v in up:
        i = int(np.argmax(np.abs(v)))
        out.append(names[(i, int(np.sign(v[i])))] if abs(abs(v[i]) - 1.0) < 1e-12 else "")
    if all(out) and len(set(out)) == len(out):
        return out
    return [f"P{k + 1}" for k in range(len(up))]


def _axis_angle(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float, bool]:
    """Unit axis and angle turning ``a`` to ``b``; ``True`` when they coincide (a wiggle)."""
    c = np.cross(a, b)
    sin, cos = np.linalg.norm(c), float(a @ b)
    angle = float(np.arctan2(sin, cos))
    if sin > 1e-9:
        return c / sin, angle, False
    perp = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
    return perp / np.linalg.norm(perp), (angle if cos < 0 else 0.0), cos > 0


def _segment(a, b, m: int, rate: float, *, lever: np.ndarray, gravity: float) -> np.ndarray:
    """Specific force ``(m, 3)`` during the motion from direction ``a`` to ``b``."""
    axis, angle, wiggle = _axis_angle(a, b)
    dur = m / rate
    tau = (np.arange(m) + 1.0) / (m + 1.0)
    if wiggle:  # out and back: theta = W (1 - cos 2 pi tau) / 2
        th = WIGGLE * (1.0 - np.cos(2 * np.pi * tau)) / 2.0
        th1 = WIGGLE * np.pi * np.sin(2 * np.pi * tau) / dur
        th2 = WIGGLE * 2.0 * np.pi**2 * np.cos(2 * np.pi * tau) / dur**2
    else:  # quintic smooth step
        th = angle * (10 * tau**3 - 15 * tau**4 + 6 * tau**5)
        th1 = angle * (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / dur
        th2 = angle * (60 * tau - 180 * tau**2 + 120 * tau**3) / dur**2
    cos, sin = np.cos(th)[:, None], np.sin(th)[:, None]
    up = a * cos + np.cross(axis, a) * sin + axis * (axis @ a) * (1.0 - cos)  # Rodrigues
    # Body rates: a fixed world vector turns by +theta about axis in the body frame,
    # so omega = -theta' axis and alpha = -theta'' axis.
    omega, alpha = -th1[:, None] * axis, -th2[:, None] * axis
    kinematic = np.cross(alpha, lever) + np.cross(omega, np.cross(omega, lever))
    return gravity * up + kinematic


def _check(value, name: str, low: float, *, strict: bool = True) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = float("nan")
    if not np.isfinite(x) or (x <= low if strict else x < low):
        raise AccelcalError(f"{value!r} must be a finite number {'>' if strict else '>='} {low:g}",
                            parameter=name)
    return x


def simulate(calibration, up, *, rate: float = 100.0, dwell: float = 5.0, motion: float = 2.0,
             still: float = 30.0, noise_sd: float = 0.0, seed=None, gravity: float = 9.80665,
             lever_arm=(0.05, 0.03, 0.02), labels=None, axis_models=None) -> TriadRecord:
    """A triad recording of ``calibration`` through static positions.

    Parameters
    ----------
    calibration : TriadCalibration
        The simulated triad (its input unit is the record's).
    up : array_like, shape (n, 3), or int
        The positions' unit gravity-opposing directions in the fixture
        frame, or a number of random directions (uniform on the sphere).
    rate : float
        Sample rate, Hz.
    dwell, motion, still : float
        Seconds held at each position, of each motion, and of the initial
        still period (added to the first position's dwell).
    noise_sd : float
        White-noise SD per sample and axis, input unit.
    seed : int or numpy.random.Generator, optional
        Randomness (directions and noise).
    gravity : float
        Local gravity, m/s^2.
    lever_arm : array_like, shape (3,)
        Sensor position from the pivot of the motions, m (fixture frame).
    labels : sequence of str, optional
        Position labels (default imucal's x_p ... for the six axis
        directions, else P1..Pn).
    axis_models : "default" or sequence of three ErrorModel, optional
        Simulate each axis as a pendulous accelerometer with these error
        models' terms beyond the calibration's (K2, K3, K4, cross-coupling,
        odd-input, asymmetry: :func:`accelcal.rigs.triad_axes.pendulous_readings`);
        ``"default"``: the embedded default accelerometer
        (:func:`accelcal.default_model`) on every axis. Default: the triad
        model alone.

    Returns
    -------
    TriadRecord
        ``positions`` with the sample range of each static interval;
        metadata ``gravity``, ``noise_sd``, ``rate``, ``seed`` (when an int),
        ``true_calibration``, ``simulated: true``.

    Raises
    ------
    AccelcalError
        For bad directions, non-positive rate/dwell/motion, negative still or
        noise, a recording too long for memory or a record, or outputs beyond
        a record's range.
    """
    from accelcal.physics.gravity import check_gravity

    rng = generator(seed)
    if isinstance(up, int | np.integer) and not isinstance(up, bool):
        if not 1 <= up <= 100_000:
            raise AccelcalError(f"{up} must be a number of positions in 1..100000",
                                parameter="up")
        dirs = random_directions(int(up), rng)
    else:
        dirs = np.array(up, dtype=float)
        if dirs.ndim != 2 or dirs.shape[1] != 3 or not len(dirs) or not np.isfinite(dirs).all():
            raise AccelcalError(f"must be unit vectors of shape (n, 3) or a number of positions; "
                                f"got shape {dirs.shape}", parameter="up")
        norm = np.linalg.norm(dirs, axis=1)
        if np.abs(norm - 1.0).max() > 0.01:
            raise AccelcalError("must be unit vectors (norms within 1 % of 1)", parameter="up")
        dirs = dirs / norm[:, None]
    rate = _check(rate, "rate", 0.0)
    dwell, motion = _check(dwell, "dwell", 0.0), _check(motion, "motion", 0.0)
    still = _check(still, "still", 0.0, strict=False)
    noise_sd = _check(noise_sd, "noise_sd", 0.0, strict=False)
    g = check_gravity(gravity)
    lever = np.asarray(lever_arm, dtype=float)
    if lever.shape != (3,) or not np.isfinite(lever).all() or np.abs(lever).max() > 10:
        raise AccelcalError("must be three finite lengths within 10 m", parameter="lever_arm")
    n = len(dirs)
    names = _labels(dirs) if labels is None else [str(x) for x in labels]
    if len(names) != n:
        raise AccelcalError(f"{len(names)} labels for {n} positions", parameter="labels")
    planned = (still + n * dwell + (n - 1) * motion) * rate  # a float: checked before rounding
    if not planned <= MAX_SAMPLES:
        raise AccelcalError(f"the recording would hold {planned:.3g} samples, more than a record "
                            f"holds ({MAX_SAMPLES}); lower the rate, the times or the positions",
                            parameter="rate")
    if noise_sd > MAX_VALUE / 10:
        raise AccelcalError(f"a noise SD of {noise_sd:g} makes outputs beyond the {MAX_VALUE:g} "
                            "a record holds", parameter="noise_sd")
    n_dwell, n_move, n_still = round(dwell * rate), round(motion * rate), round(still * rate)
    if min(n_dwell, n_move) < 1:
        raise AccelcalError("dwell and motion must each last at least one sample at this rate",
                            parameter="rate")
    total = n_still + n * n_dwell + (n - 1) * n_move
    if total > MAX_SAMPLES:
        raise AccelcalError(f"{total} samples are more than a record holds ({MAX_SAMPLES}); "
                            "lower the rate, the dwell or the positions", parameter="rate")
    work.simulated("triad", f"a triad recording at {rate:g} Hz", total, parameter="rate",
                   hint="lower the rate, the dwell or the positions")
    check_memory(total, 3, MEMORY_FACTOR, f"a triad recording of {total} samples",
                 parameter="rate")
    force, positions, start = [], [], 0
    for k in range(n):
        if k:
            force.append(_segment(dirs[k - 1], dirs[k], n_move, rate, lever=lever, gravity=g))
            start += n_move
        length = n_dwell + (n_still if k == 0 else 0)
        force.append(np.repeat(g * dirs[k][None], length, axis=0))
        positions.append({"label": names[k], "up": dirs[k].tolist(), "start": start,
                          "stop": start + length})
        start += length
    frame = "reference" if calibration.rotation is not None else "body"
    if axis_models is None:
        acc = calibration.readings(np.concatenate(force), frame=frame)
    else:
        from accelcal.rigs.triad_axes import pendulous_readings

        if isinstance(axis_models, str) and axis_models == "default":
            from accelcal.defaults import default_model

            axis_models = (default_model(),) * 3
        acc = pendulous_readings(calibration, np.concatenate(force), frame, axis_models, g)
    if noise_sd > 0:
        acc = acc + noise_sd * rng.standard_normal(acc.shape)
    if not np.abs(acc).max() <= MAX_VALUE:
        raise AccelcalError(f"the simulated outputs exceed the {MAX_VALUE:g} a record holds; "
                            "check the calibration's scale factors and unit")
    meta = {"gravity": g, "noise_sd": noise_sd, "rate": rate, "simulated": True,
            "true_calibration": calibration.to_dict()}
    if axis_models is not None:
        meta["axis_models"] = [m.to_dict() if hasattr(m, "to_dict") else str(m)
                               for m in axis_models]
    if isinstance(seed, int | np.integer):
        meta["seed"] = int(seed)
    return TriadRecord(np.arange(total) / rate, acc, calibration.input_unit, positions, meta)
