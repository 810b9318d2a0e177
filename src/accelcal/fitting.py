"""Linear least squares with covariance, for every method.

One routine, :func:`least_squares`, solves ``y ~ A x`` by QR (keeping the
conditioning of ``A`` instead of squaring it), decides the rank with the
one tolerance of :mod:`accelcal.identifiability`, and returns an
:class:`~accelcal.results.Estimate` with residuals and degrees of freedom.

References
----------
.. [1] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.3.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.identifiability import analyse
from accelcal.results import Estimate


def least_squares(design, y, names, units, method, *, sigma=None, notes=(), provenance=None):
    """Ordinary (or weighted) linear least squares with covariance.

    Solves ``y ~ design @ x``. With ``sigma`` (known standard deviation of
    each observation, scalar or shape ``(n,)``) the fit is weighted and the
    covariance is ``(A' W A)^-1``; without it the residual variance
    ``s^2 = r'r / (n - p)`` scales ``(A'A)^-1``.

    Parameters
    ----------
    design : array_like, shape (n, p)
    y : array_like, shape (n,)
    names, units, method, notes, provenance
        Passed to :class:`~accelcal.results.Estimate`.
    sigma : float or array_like, optional
        Known observation standard deviations.

    Returns
    -------
    Estimate

    Raises
    ------
    AccelcalError
        If the design is rank deficient (the message gives the rank and the
        combinations it determines) or has no residual degrees of freedom
        when ``sigma`` is not known.

    References
    ----------
    .. [1] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.3.
    """
    A = np.asarray(design, dtype=float)
    y = np.asarray(y, dtype=float)
    n, p = A.shape
    if sigma is not None:
        w = 1.0 / np.broadcast_to(np.asarray(sigma, dtype=float), (n,))
        Aw, yw = A * w[:, None], y * w
    else:
        Aw, yw = A, y
    q, r = np.linalg.qr(Aw)
    ident = analyse(r, names)  # R has A's singular values: the rank in O(p^3)
    if ident.rank < p:
        lost = ", ".join(ident.unidentifiable)
        raise AccelcalError(
            f"{method}: the design has rank {ident.rank} < {p} unknowns ({', '.join(names)}); "
            f"{lost} cannot be separated; add positions or amplitudes that separate them, "
            "or fix some terms"
        )
    x = np.linalg.solve(r, q.T @ yw)
    resid = y - A @ x
    rinv = np.linalg.inv(r)
    cov_unit = rinv @ rinv.T
    dof = n - p
    if sigma is None:
        if dof <= 0:
            raise AccelcalError(
                f"{method}: {n} observations for {p} unknowns leave no degrees of freedom to "
                "estimate the noise; add observations or give the noise level"
            )
        cov = cov_unit * float(resid @ resid) / dof
    else:
        cov = cov_unit
    return Estimate(
        names=tuple(names), values=x, covariance=cov, units=dict(units), method=method,
        residuals=resid, dof=dof, notes=tuple(notes), provenance=dict(provenance or {}),
    )
