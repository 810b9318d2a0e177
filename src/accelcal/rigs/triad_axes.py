"""A triad whose axes are pendulous accelerometers: each axis's error model beyond the triad's.

The triad model (:mod:`accelcal.methods.triad.model`) holds each axis's
bias, scale factor and direction; a real axis is a pendulous
accelerometer whose output also has the terms of the IEEE 1293 error model
[Guan2021]_: K2 a_i², K3 a_i³, K4 a_i⁴, the cross-coupling Kio a_i a_o,
Kip a_i a_p, Kop a_o a_p, the odd-input terms Koo a_o², Kpp a_p² and the
asymmetry ``sgn(a_i)(K0' + K1' a_i)/2``. :func:`pendulous_readings`
adds them to the readings of a calibration, per axis, with the axis's
K0, K1, Ko, Kp left to the calibration (its bias, scale factor and the
axis direction the triangular ``T`` holds).

Each axis's frame: IA is the axis's sensing direction ``n_i`` (row i of
``T^-1`` normalised), PA the next body axis (x -> y -> z -> x) made
orthogonal to IA, OA = PA x IA, so that IA, OA, PA is right-handed.

References
----------
.. [Guan2021] Guan et al., the error model of a pendulous accelerometer, eqs. (1)-(3).
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., ICRA 2014, eq. (8).
"""

import dataclasses

import numpy as np

from accelcal.errors import AccelcalError

CALIBRATION_TERMS = ("K0", "K1", "Ko", "Kp")
"""Terms of an axis's error model the triad calibration itself holds (bias, scale factor,
direction): not added by :func:`pendulous_readings`."""


def axis_frames(t_matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """IA, OA, PA unit vectors ``(3, 3)`` (row i: axis i) and ``|row i of T^-1|`` ``(3,)``."""
    r = np.linalg.inv(np.asarray(t_matrix, dtype=float))
    norm = np.linalg.norm(r, axis=1)
    ia = r / norm[:, None]
    pa = np.empty((3, 3))
    for i in range(3):
        e = np.eye(3)[(i + 1) % 3]
        v = e - (e @ ia[i]) * ia[i]
        pa[i] = v / np.linalg.norm(v)
    oa = np.cross(pa, ia)
    return ia, oa, pa, norm


def pendulous_readings(calibration, force, frame: str, models, gravity: float) -> np.ndarray:
    """The calibration's readings of ``force`` plus each axis's pendulous error terms.

    Parameters
    ----------
    calibration : TriadCalibration
    force : numpy.ndarray, shape (N, 3)
        Specific force, m/s^2, in ``frame``.
    frame : {"body", "reference"}
    models : sequence of three ErrorModel
        Each axis's error model; its K0, K1, Ko, Kp (:data:`CALIBRATION_TERMS`)
        and noise are ignored (the calibration's).
    gravity : float
        m/s^2 per g.

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        Readings in the calibration's input unit.

    Raises
    ------
    AccelcalError
        Without three models.
    """
    models = tuple(models)
    if len(models) != 3:
        raise AccelcalError(f"needs three axis models, got {len(models)}", parameter="axis_models")
    u = calibration.readings(force, frame=frame)
    arr = np.asarray(force, dtype=float)
    if frame == "reference" and calibration.rotation is not None:
        arr = arr @ calibration.rotation
    ia, oa, pa, norm = axis_frames(calibration.t)
    a_i, a_o, a_p = (arr @ m.T / gravity for m in (ia, oa, pa))  # (N, 3) each, g
    extra = np.empty_like(u)
    for i, model in enumerate(models):
        bare = dataclasses.replace(model, **{**dict.fromkeys(CALIBRATION_TERMS, 0.0), "K1": 1.0},
                                   sigma=0.0, temperature=None)
        extra[:, i] = bare.output_g(a_i[:, i], a_o[:, i], a_p[:, i]) - a_i[:, i]
    # w_i = |r_i| a_i (m/s^2) is the axis's scaled reading: the terms add |r_i| g e_i to it
    return u + extra * gravity * norm / calibration.scale
