"""Results of reductions: estimates with covariance, residuals and provenance.

Coefficients are values and estimators are separate: every reduction returns
an :class:`Estimate`, a frozen record of what it found, never a half-filled
mutable object. Tables and reports are built from these, not from printed
strings.
"""

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Estimate:
    """Estimated parameters with their covariance.

    Parameters
    ----------
    names : tuple of str
        Parameter names, in the order of ``values``.
    values : numpy.ndarray
        Estimates, shape ``(p,)``.
    covariance : numpy.ndarray
        Covariance of the estimates, shape ``(p, p)``; NaN where a quantity
        is not identifiable.
    units : dict
        Unit of each parameter by name.
    method : str
        Name of the reduction that produced it.
    residuals : numpy.ndarray, optional
        Residuals of the fit (observed minus fitted), in the data's unit.
    dof : int
        Degrees of freedom of the residuals (observations minus parameters).
    notes : tuple of str
        Caveats: unidentifiable parameters, errata applied, assumptions.
    provenance : dict
        Inputs' description (file names, hashes, settings).
    """

    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    units: dict[str, str]
    method: str
    residuals: np.ndarray | None = None
    dof: int = 0
    notes: tuple[str, ...] = ()
    provenance: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = np.asarray(self.values, dtype=float)
        cov = np.asarray(self.covariance, dtype=float)
        p = len(self.names)
        if values.shape != (p,) or cov.shape != (p, p):
            raise ValueError(
                f"Estimate: {p} names need values of shape ({p},) and covariance ({p}, {p}); "
                f"got {values.shape} and {cov.shape}"
            )
        values.setflags(write=False)
        cov.setflags(write=False)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "names", tuple(self.names))

    @property
    def std(self) -> np.ndarray:
        """Standard uncertainties (square roots of the covariance diagonal)."""
        return np.sqrt(np.diag(self.covariance))

    def __getitem__(self, name: str) -> float:
        """The estimate of parameter ``name``."""
        return float(self.values[self.names.index(name)])

    def std_of(self, name: str) -> float:
        """The standard uncertainty of parameter ``name``."""
        i = self.names.index(name)
        return float(np.sqrt(self.covariance[i, i]))

    def as_dict(self) -> dict[str, float]:
        """Estimates by name."""
        return dict(zip(self.names, self.values.tolist(), strict=True))

    def rows(self) -> list[dict]:
        """One dict per parameter: name, estimate, std, unit (for tables and files)."""
        return [
            {"coefficient": n, "estimate": float(v), "std": float(s), "unit": self.units.get(n, "")}
            for n, v, s in zip(self.names, self.values, self.std, strict=True)
        ]

    def to_frame(self):
        """The estimates as a pandas DataFrame (pandas imported lazily)."""
        import pandas as pd

        return pd.DataFrame(self.rows()).set_index("coefficient")


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
        Passed to :class:`Estimate`.
    sigma : float or array_like, optional
        Known observation standard deviations.

    Returns
    -------
    Estimate

    Raises
    ------
    accelcal.errors.AccelcalError
        If the design is rank deficient (the message gives the rank) or has
        no residual degrees of freedom when ``sigma`` is not known.

    References
    ----------
    .. [1] Golub G. H., Van Loan C. F., Matrix Computations, 4th ed., sec. 5.3.
    """
    from accelcal.errors import AccelcalError

    A = np.asarray(design, dtype=float)
    y = np.asarray(y, dtype=float)
    n, p = A.shape
    if sigma is not None:
        w = 1.0 / np.broadcast_to(np.asarray(sigma, dtype=float), (n,))
        Aw, yw = A * w[:, None], y * w
    else:
        Aw, yw = A, y
    # QR keeps the conditioning of A rather than squaring it as A'A would.
    q, r = np.linalg.qr(Aw)
    diag = np.abs(np.diag(r))
    tol = diag.max(initial=0.0) * max(n, p) * np.finfo(float).eps
    rank = int((diag > tol).sum())
    if rank < p:
        raise AccelcalError(
            f"{method}: the design has rank {rank} < {p} unknowns ({', '.join(names)}); "
            "add positions or amplitudes that separate them, or fix some terms"
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
