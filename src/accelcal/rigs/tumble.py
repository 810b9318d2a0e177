"""Multipoint tumble rig: readings of an accelerometer turned through N positions.

The accelerometer is turned about its output axis (OA) or pendulum axis
(PA) in the gravity field (1 g) and read R times at each position. The
specific force at a position theta is that of
:func:`accelcal.methods.tumble.specific_force`; the output is the error
model's (:meth:`accelcal.model.ErrorModel.output`) with Gaussian noise of a
given SD per reading. An optional Gaussian position error (the head's
setting error, one draw per position) perturbs the true angle while the
record keeps the nominal one. Simulation only: the record is a
:class:`accelcal.io.formats.tumble.TumbleRecord`, written and read by that
format module.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
.. [DOMAIN] accelcal domain notes, section 5.
"""

import numpy as np

from accelcal import work
from accelcal.errors import AccelcalError
from accelcal.io.formats.tumble import MAX_ANGLE, MAX_OUTPUT, TumbleRecord
from accelcal.model import ErrorModel
from accelcal.physics.tumble import specific_force
from accelcal.resources import check_memory, generator

MEMORY_FACTOR = 12
"""Arrays of (positions x repeats) float64 a simulation holds at its peak: the three
specific-force components, the output and its noise, the record and the columns
written (about 9 measured); 12 leaves a margin."""


def uniform_positions(n: int, start: float = 0.0) -> np.ndarray:
    """``n`` equally spaced positions from ``start``, rad.

    Raises
    ------
    AccelcalError
        For ``n`` that is not an integer >= 1, a ``start`` that is not finite
        or beyond the :data:`~accelcal.io.formats.tumble.MAX_ANGLE` a tumble
        record holds, or more positions than fit in memory.
    """
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise AccelcalError(f"{n!r} must be an integer of at least 1", parameter="points")
    if not abs(start) <= np.radians(MAX_ANGLE) - 2.0 * np.pi:
        raise AccelcalError(f"{np.degrees(start):.6g} deg must be a finite angle within "
                            f"+-{MAX_ANGLE:g} deg (a few thousand turns, what a tumble record "
                            "holds)", parameter="start")
    check_memory(n, 1, MEMORY_FACTOR, f"{n} tumble positions", parameter="points")
    return start + np.arange(n) * 2.0 * np.pi / n


def simulate(
    positions_rad,
    model: ErrorModel,
    *,
    rotation_axis: str = "OA",
    noise: float | None = None,
    repeats: int = 1,
    position_sd: float = 0.0,
    seed=None,
) -> TumbleRecord:
    """Readings of ``model`` at the positions, ``repeats`` at each.

    Parameters
    ----------
    positions_rad : array_like, shape (N,)
        Nominal positions theta_j, rad.
    model : ErrorModel
        The accelerometer (its output unit is the record's).
    rotation_axis : {"OA", "PA"}
        Axis the accelerometer is turned about.
    noise : float, optional
        Noise SD of one reading, output unit; default the model's
        ``sigma * |K1|``. 0 gives noise-free readings.
    repeats : int
        Readings per position (R >= 1).
    position_sd : float
        SD of the position error, rad (one draw per position; 0: none).
    seed : int or numpy.random.Generator, optional
        Randomness (``numpy.random.default_rng(seed)``).

    Returns
    -------
    TumbleRecord
        Outputs of shape (N, R); metadata ``noise_sd``, ``simulated``
        (true: the laboratory field that marks simulated data, see
        :mod:`accelcal.io.lab_metadata`), ``seed`` (when an int),
        ``true_model`` (the model's terms with ``sigma`` the noise in g) and
        ``position_sd_rad`` (when non-zero).

    Raises
    ------
    AccelcalError
        For positions that are not a non-empty 1-D finite array (within the
        :data:`~accelcal.io.formats.tumble.MAX_ANGLE` a record holds),
        ``repeats`` below 1, a negative or non-finite ``noise`` or
        ``position_sd``, a negative seed, an unknown axis, readings that
        would not fit in memory, or outputs that overflow (or exceed the
        :data:`~accelcal.io.formats.tumble.MAX_OUTPUT` a record holds).

    References
    ----------
    .. [1] IEEE1293, multipoint tumble; DOMAIN section 5.

    Examples
    --------
    >>> from accelcal import ErrorModel
    >>> rec = simulate(uniform_positions(8), ErrorModel(K1=1.2, K0=1e-4), noise=0.0)
    >>> rec.outputs.shape, round(float(rec.outputs[0, 0]), 6)
    ((8, 1), 1.20012)
    """
    positions = np.asarray(positions_rad, dtype=float)
    if positions.ndim != 1 or positions.size == 0 or not np.isfinite(positions).all():
        raise AccelcalError(
            f"positions must be a non-empty 1-D array of finite angles in rad; got shape "
            f"{positions.shape}", parameter="positions_rad"
        )
    if np.abs(positions).max() > np.radians(MAX_ANGLE):
        raise AccelcalError(f"positions beyond {MAX_ANGLE:g} deg cannot be recorded; give "
                            "angles within a few turns", parameter="positions_rad")
    if isinstance(repeats, bool) or not isinstance(repeats, int | np.integer) or repeats < 1:
        raise AccelcalError(f"{repeats!r} must be an integer of at least 1", parameter="repeats")
    if noise is None:
        noise = model.sigma * abs(model.K1)
    if not np.isfinite(noise) or noise < 0:
        raise AccelcalError(f"{noise} must be a finite SD >= 0 (output unit)", parameter="noise")
    if noise > MAX_OUTPUT:
        raise AccelcalError(f"{noise:.3g} is beyond the {MAX_OUTPUT:g} (output unit) a tumble "
                            "record holds, and any accelerometer's noise", parameter="noise")
    if not np.isfinite(position_sd) or position_sd < 0:
        raise AccelcalError(f"{position_sd} must be a finite SD >= 0 (rad)",
                            parameter="position_sd")
    check_memory(positions.size, repeats, MEMORY_FACTOR,
                 f"{positions.size} tumble positions x {repeats} readings", parameter="repeats")
    work.simulated("tumble", f"{positions.size} tumble positions x {repeats} readings",
                   float(positions.size) * repeats, parameter="points",
                   hint="give fewer points or repeats")
    rng = generator(seed)
    model = model.replace(sigma=noise / abs(model.K1))
    true = positions
    if position_sd > 0:
        true = positions + rng.normal(0.0, position_sd, size=positions.size)
    a_i, a_o, a_p = specific_force(np.repeat(true, repeats), rotation_axis)
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is refused below
        output = model.output(a_i, a_o, a_p, rng=rng)
    if not np.abs(output).max() <= MAX_OUTPUT:
        raise AccelcalError(f"the simulated outputs overflow (exceed the {MAX_OUTPUT:g} a "
                            "tumble record holds, or are not finite): the noise or the model's "
                            "coefficients are beyond any accelerometer")
    meta = {"noise_sd": float(noise), "simulated": True}
    if isinstance(seed, int | np.integer):
        meta["seed"] = int(seed)
    meta["true_model"] = model.terms()
    if position_sd > 0:
        meta["position_sd_rad"] = float(position_sd)
    return TumbleRecord(positions, output.reshape(positions.size, repeats), rotation_axis,
                        model.output_unit, meta)
