"""Single-sensor reduction of indexing-head data, and each sensor's own scale factor.

Each sensor alone is fitted by least squares on Psi(beta_k); the head's
angle error is not modelled and biases every coefficient. The same fit
gives the scale factor every other reduction normalises by ([DOMAIN]
step 0).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, section 3 and Table 2.
.. [DOMAIN] accelcal domain notes, section 4, step 0.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.fitting import least_squares
from accelcal.methods.dividing_head.data import HeadData
from accelcal.methods.dividing_head.result import K_O_STAR, head_reduction
from accelcal.methods.dividing_head.theory import COEFFICIENTS, coefficient_units, psi
from accelcal.results import Reduction


def single_pinv(beta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares operator ``(K, 5, n)`` and ``(Psi' Psi)^-1`` ``(K, 5, 5)``: O(n)."""
    a = psi(beta)
    cov_unit = np.linalg.inv(np.swapaxes(a, -1, -2) @ a)
    return cov_unit @ np.swapaxes(a, -1, -2), cov_unit


def single_operator(beta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares operators of the single-sensor fit for angles ``beta`` ``(K, n)``.

    The residual operator is ``n x n`` per sensor: for the Monte Carlo
    paths (fixed, small position counts); reductions use :func:`single_pinv`.

    Returns
    -------
    pinv : numpy.ndarray, shape (K, 5, n)
        Estimates = pinv @ U.
    hat_residual : numpy.ndarray, shape (K, n, n)
        Residuals = hat_residual @ U.
    cov_unit : numpy.ndarray, shape (K, 5, 5)
        (Psi' Psi)^-1.
    """
    pinv, cov_unit = single_pinv(beta)
    n = beta.shape[-1]
    return pinv, np.eye(n) - psi(beta) @ pinv, cov_unit


def single(data: HeadData) -> Reduction:
    """Each sensor alone: least squares on Psi(beta_k).

    The head error enters every coefficient: harmonics 0-3 of d_alpha bias
    K_F, K_I, K_O, K_IO, K_II and the rest inflates the residual.

    Returns
    -------
    Reduction
        Method ``dividing-head/single``: per-sensor estimates with their own
        residual variance (no shared head error).

    Raises
    ------
    AccelcalError
        With fewer than 6 positions (5 unknowns and one degree of freedom).

    References
    ----------
    .. [1] Dong2014, section 3 and Table 2 (single-sensor method).
    """
    need_positions(data, 6, "single")
    units = coefficient_units(data.output_unit)
    estimates = tuple(
        least_squares(psi(b), u, COEFFICIENTS, units, "single")
        for b, u in zip(data.angles(), data.outputs, strict=True)
    )
    return head_reduction(data, "single", estimates, dof=estimates[0].dof,
                          assumptions=(K_O_STAR,))


def scale_factors(data_or_beta, outputs=None) -> np.ndarray:
    """Each sensor's own scale factor from a single-sensor fit [DOMAIN step 0].

    Parameters
    ----------
    data_or_beta : HeadData or numpy.ndarray
        The data, or the angles beta ``(K, n)`` with ``outputs (..., K, n)``.
    outputs : numpy.ndarray, optional
        Outputs when angles are given.

    Returns
    -------
    numpy.ndarray, shape (..., K)
        The sine coefficient of the Psi fit, output unit per g.
    """
    if isinstance(data_or_beta, HeadData):
        beta, outputs = data_or_beta.angles(), data_or_beta.outputs
    else:
        beta = data_or_beta
    pinv = single_pinv(beta)[0]
    k_i = np.einsum("kn,...kn->...k", pinv[:, 1, :], outputs)
    if (np.abs(k_i) == 0).any():
        raise AccelcalError("a sensor's fitted scale factor is zero; check the output columns")
    return k_i


def need_positions(data: HeadData, minimum: int, method: str) -> None:
    """Refuse fewer than ``minimum`` positions for ``method``."""
    n = data.positions.size
    if n < minimum:
        raise AccelcalError(
            f"method {method}: {n} positions for 5 unknowns per sensor; give at least {minimum}"
        )
