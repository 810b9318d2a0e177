"""The threshold factor of static detection, chosen by the triad calibration's residual.

Tedaldi [1]_ (sec. III) picks the factor k of the static detector
(:func:`accelcal.signal.static.detect_static`) by the residual of the
calibration: :func:`choose_factor` sweeps k and keeps the one whose
intervals give the smallest root-mean-square gravity-norm residual after
the unknown-orientation calibration (the RMS per interval rather than the
sum makes sets of different sizes comparable).

References
----------
.. [1] D. Tedaldi, A. Pretto, E. Menegatti, "A robust and easy to implement
   method for IMU calibration without external equipments", IEEE ICRA 2014,
   pp. 3042-3049.
.. [2] imu_tk (A. Pretto), the threshold sweep of ``MultiPosCalibration``
   (reference implementation of [1]).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.signal.static import StaticIntervals, detect_static

DEFAULT_FACTORS = tuple(float(k) for k in range(2, 11))
"""Threshold factors of the sweep: 2..10, as imu_tk sweeps them [2]_."""


@dataclass(frozen=True)
class FactorChoice:
    """The threshold sweep of :func:`choose_factor`.

    The ``factor`` kept, its ``intervals`` and gravity-norm ``reduction``,
    and the sweep's ``rows`` (factor, intervals, rms_residual, note: NaN and
    the reason where a factor gave too few intervals to calibrate).
    """

    factor: float
    intervals: StaticIntervals
    reduction: object
    rows: list


def choose_factor(values, rate: float, gravity: float, *, factors=DEFAULT_FACTORS,
                  init_static: float = 30.0, window: float = 1.0, min_length: float = 2.0,
                  input_unit: str = "m/s^2", quadratic: bool = False, time=None,
                  exclude=None) -> FactorChoice:
    """Choose the threshold factor by the calibration residual ([1]_ sec. III).

    For each factor the intervals are detected and calibrated by the
    gravity-norm route (:func:`accelcal.methods.triad.unknown.calibrate_unknown`);
    the factor whose calibration leaves the smallest RMS of ``|a_k| - g``
    over its intervals wins.

    Parameters
    ----------
    values : array_like
        Samples, ``(n, 3)``.
    rate : float
        Sample rate, Hz.
    gravity : float
        Local gravity, m/s^2.
    factors : sequence of float
        Factors to try (default 2..10).
    init_static, window, min_length : float
        As for :func:`detect_static`, seconds.
    input_unit, quadratic, time
        Unit of ``values``; fit the quadratic terms too; sample times (s).
    exclude : array_like of bool, optional
        Samples never static (clipped), as for :func:`detect_static`.

    Returns
    -------
    FactorChoice

    Raises
    ------
    AccelcalError
        When no factor gives enough intervals to calibrate (the message
        gives the most intervals found), or for bad settings.
    """
    from accelcal.methods.triad.common import calibration_of, norm_residuals
    from accelcal.methods.triad.unknown import calibrate_unknown

    factors = [float(k) for k in factors]
    if not factors:
        raise AccelcalError("give at least one factor", parameter="factors")
    best, rows, most, dropped = None, [], 0, 0
    for k in factors:
        row = {"factor": k, "intervals": 0, "rms_residual": float("nan"), "note": ""}
        try:
            found = detect_static(values, rate, init_static=init_static, window=window,
                                  factor=k, min_length=min_length, time=time,
                                  exclude=exclude)
            dropped = max(dropped, found.excluded.get("dropped", 0))
            row["intervals"] = len(found)
            most = max(most, len(found))
            # as without the sweep: weights by the samples averaged, the variance from
            # the residuals (the intervals' own sample SDs would leave out every error
            # that is not white noise)
            red = calibrate_unknown(found.means, gravity, input_unit=input_unit,
                                    quadratic=quadratic, counts=found.counts)
        except AccelcalError as exc:
            if "no still period" in str(exc):
                raise
            row["note"] = str(exc)
            rows.append(row)
            continue
        res = norm_residuals(found.means, gravity, calibration_of(red))
        row["rms_residual"] = float(np.sqrt(np.mean(np.square(res))))
        rows.append(row)
        if best is None or row["rms_residual"] < best[0]:
            best = (row["rms_residual"], k, found, red)
    if best is None:
        raise AccelcalError(
            f"no threshold factor of {', '.join(f'{k:g}' for k in factors)} gives static "
            f"intervals that calibrate the triad (most intervals found: {most}"
            + (f"; up to {dropped} dropped for clipped samples" if dropped else "") + "); "
            + (rows[-1]["note"] if rows else ""))
    return FactorChoice(factor=best[1], intervals=best[2], reduction=best[3], rows=rows)
