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

from accelcal.errors import AccelcalError
from accelcal.io.formats.tumble import TumbleRecord
from accelcal.methods.tumble.geometry import specific_force
from accelcal.model import ErrorModel


def uniform_positions(n: int, start: float = 0.0) -> np.ndarray:
    """``n`` equally spaced positions from ``start``, rad."""
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
        Outputs of shape (N, R); metadata ``noise_sd``, ``seed`` (when an
        int), ``true_model`` (the model's terms with ``sigma`` the noise in g)
        and ``position_sd_rad`` (when non-zero).

    Raises
    ------
    AccelcalError
        For positions that are not a non-empty 1-D finite array, ``repeats``
        below 1, a negative or non-finite ``noise`` or ``position_sd``, or
        an unknown axis.

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
    if isinstance(repeats, bool) or not isinstance(repeats, int | np.integer) or repeats < 1:
        raise AccelcalError(f"{repeats!r} must be an integer of at least 1", parameter="repeats")
    if noise is None:
        noise = model.sigma * abs(model.K1)
    if not np.isfinite(noise) or noise < 0:
        raise AccelcalError(f"{noise} must be a finite SD >= 0 (output unit)", parameter="noise")
    if not np.isfinite(position_sd) or position_sd < 0:
        raise AccelcalError(f"{position_sd} must be a finite SD >= 0 (rad)",
                            parameter="position_sd")
    rng = np.random.default_rng(seed)
    model = model.replace(sigma=noise / abs(model.K1))
    true = positions
    if position_sd > 0:
        true = positions + rng.normal(0.0, position_sd, size=positions.size)
    a_i, a_o, a_p = specific_force(np.repeat(true, repeats), rotation_axis)
    output = model.output(a_i, a_o, a_p, rng=rng)
    meta = {"noise_sd": float(noise)}
    if isinstance(seed, int | np.integer):
        meta["seed"] = int(seed)
    meta["true_model"] = model.terms()
    if position_sd > 0:
        meta["position_sd_rad"] = float(position_sd)
    return TumbleRecord(positions, output.reshape(positions.size, repeats), rotation_axis,
                        model.output_unit, meta)
