"""Temperature polynomials by weighted least squares, with the order chosen by an F-test.

A coefficient estimated at P plateaus, ``y_j`` with standard uncertainty
``s_j`` at sensor temperature ``T_j``, is fitted by ::

    y_j = sum_{k=0..m} c_k (T_j - T0)^k + d_j H + e_j,   e_j ~ N(0, sigma^2 s_j^2)

with ``d_j = +1/2`` for a plateau reached by heating and ``-1/2`` by cooling
(``H`` is the hysteresis, heating minus cooling; the term is left out when
the plateaus do not separate it). The weights ``1/s_j^2`` are the plateau
reductions' (their noise pooled over every plateau's residuals, so known to
many degrees of freedom). The covariance is ``(A' W A)^-1`` scaled by the
Birge ratio squared ``R_B^2 = chi^2 / nu`` (``nu = P - q`` degrees of
freedom, q parameters) only when the scatter between plateaus exceeds what
the plateaus' covariance explains (``R_B > 1``: repeatability, unmodelled
thermal effects), so that such scatter widens the intervals rather than
hiding in them; otherwise the covariance is the plateaus' own, with their
degrees of freedom. Rescaling always (down as well as up) would rest the
intervals on the nu = 4 to 11 residual degrees of freedom of the
polynomial: at order 2 the stated SD of a temperature coefficient would
vary several times between repeated runs [Birge; GUM G.3; NIST/SEMATECH
4.4.3].

Order selection (``order="auto"``): starting at m = 1, the order is raised
while the extra-sum-of-squares F-test of the added power rejects, at level
``alpha`` (default 0.05), the hypothesis that its coefficient is zero ::

    F = (chi^2_m - chi^2_{m+1}) / (chi^2_{m+1} / nu_{m+1}) ~ F(1, nu_{m+1})    # Eq. (3) [Draper]

up to order 3 or as far as the plateaus allow (nu >= 1). The interval of
the chosen fit is then conditional on the choice (docs/thermal.md).

References
----------
.. [Draper] Draper N. R., Smith H., Applied Regression Analysis, 3rd ed.,
   Wiley 1998, secs. 6.1 (extra sum of squares) and 12.1 (polynomial models).
.. [GUM] JCGM 100:2008, G.3 (degrees of freedom of a Type A evaluation).
.. [NIST] NIST/SEMATECH e-Handbook of Statistical Methods, sec. 4.4.3
   (weighted least squares).
.. [Birge] Birge R. T., The calculation of errors by the method of least
   squares, Phys. Rev. 40, 207-227 (1932); Kacker R., Datla R., Parr A.,
   Metrologia 39, 279-293 (2002) (the Birge ratio and when to scale).
"""

from dataclasses import dataclass

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.terms import MAX_TEMPERATURE_ORDER

ALPHA = 0.05
"""Level of the F-test that raises the order (``order="auto"``)."""


@dataclass(frozen=True)
class PolyFit:
    """A weighted polynomial fit in (T - T0).

    Attributes
    ----------
    order : int
        Highest power m.
    hysteresis : bool
        Whether the heating-minus-cooling term H is fitted (the last value).
    values : numpy.ndarray
        ``c_0 .. c_m`` (and H), shape (q,).
    covariance : numpy.ndarray
        ``max(1, R_B^2) (A' W A)^-1``, shape (q, q).
    dof : int
        Degrees of freedom of the covariance: ``nu = P - q`` when scaled by
        the Birge ratio, else those of the weights (``nu`` when not given).
    chi2 : float
        Weighted residual sum of squares.
    fitted, residuals : numpy.ndarray
        At the plateaus, shape (P,), in the data's unit (fitted includes H).
    tests : tuple of (int, float, float)
        ``(order tested, F, p-value)`` of each step of the order selection.
    birge : float
        Birge ratio ``R_B = sqrt(chi^2 / nu)``.
    residual_dof : int
        ``nu = P - q``.
    """

    order: int
    hysteresis: bool
    values: np.ndarray
    covariance: np.ndarray
    dof: int
    chi2: float
    fitted: np.ndarray
    residuals: np.ndarray
    tests: tuple = ()
    birge: float = 1.0
    residual_dof: int = 0

    @property
    def scaled(self) -> bool:
        """True when the covariance was scaled up by the Birge ratio squared."""
        return self.birge > 1.0

    def curve(self, dt) -> tuple[np.ndarray, np.ndarray]:
        """The polynomial (without H) at ``dt = T - T0`` and its standard uncertainty."""
        g = np.vander(np.atleast_1d(np.asarray(dt, dtype=float)), self.order + 1,
                      increasing=True)
        cov = self.covariance[: self.order + 1, : self.order + 1]
        return g @ self.values[: self.order + 1], np.sqrt(np.einsum("ij,jk,ik->i", g, cov, g))


def _design(dt, direction, order: int, hysteresis: bool) -> np.ndarray:
    cols = [dt**k for k in range(order + 1)]
    if hysteresis:
        cols.append(0.5 * direction)
    return np.column_stack(cols)


def _solve(y, s, A) -> tuple:
    """Weighted LS on the column-equilibrated design: values, unscaled covariance, chi2."""
    aw = A / s[:, None]
    norms = np.linalg.norm(aw, axis=0)
    q, r = np.linalg.qr(aw / norms)
    coef = np.linalg.solve(r, q.T @ (y / s)) / norms
    rinv = np.linalg.solve(r, np.eye(r.shape[0])) / norms[:, None]
    resid = y - A @ coef
    return coef, rinv @ rinv.T, float(np.sum((resid / s) ** 2)), resid


def _rank(A, s) -> int:
    aw = A / s[:, None]
    return int(np.linalg.matrix_rank(aw / np.linalg.norm(aw, axis=0), tol=1e-9))


def fit_polynomial(y, std, dt, direction, *, order="auto", alpha: float = ALPHA,
                   what: str = "coefficient", weights_dof: int | None = None) -> PolyFit:
    """Weighted polynomial fit of plateau estimates against temperature (module docs).

    Parameters
    ----------
    y, std : array_like, shape (P,)
        Estimates at the plateaus and their standard uncertainties (> 0).
    dt : array_like, shape (P,)
        Plateau temperature minus the reference T0, degC.
    direction : array_like, shape (P,)
        +1 heating, -1 cooling, 0 neither.
    order : {"auto", 1, 2, 3}
        Highest power, or chosen by the F-test (Eq. (3)).
    alpha : float
        Level of the F-test.
    what : str
        The coefficient's name, in messages.
    weights_dof : int, optional
        Degrees of freedom of the standard uncertainties ``std`` (the
        covariance's when it is not scaled); default ``nu``.

    Returns
    -------
    PolyFit

    Raises
    ------
    AccelcalError
        When the plateaus cannot determine the order asked with a degree of
        freedom left (too few plateaus at distinct temperatures).

    References
    ----------
    .. [1] Draper and Smith, secs. 6.1, 12.1; GUM G.3.
    """
    from scipy import stats

    y, s, dt, d = (np.asarray(v, dtype=float) for v in (y, std, dt, direction))
    if not (np.all(s > 0) and np.isfinite(s).all() and np.isfinite(y).all()):
        raise AccelcalError(f"{what}: the plateau estimates need finite values and positive "
                            "standard uncertainties")
    hyst = bool((d > 0).any() and (d < 0).any())
    top = MAX_TEMPERATURE_ORDER if order == "auto" else int(order)
    fits = {}
    for m in range(1, top + 1):
        A = _design(dt, d, m, hyst)
        use_h = hyst and _rank(A, s) == A.shape[1]
        if not use_h:
            A = _design(dt, d, m, False)
        if _rank(A, s) < A.shape[1] or y.size - A.shape[1] < 1:
            break
        coef, unscaled, chi2, resid = _solve(y, s, A)
        fits[m] = (coef, unscaled, chi2, resid, use_h, y.size - A.shape[1])
    if order != "auto" and top not in fits:
        raise AccelcalError(
            f"{what}: order {top} needs at least {top + 2 + hyst} plateaus at {top + 1} or more "
            f"distinct temperatures (one degree of freedom left for the scatter); there are "
            f"{y.size} at {np.unique(np.round(dt, 6)).size}: give a lower order or more "
            "plateaus", parameter="order")
    if not fits:
        raise AccelcalError(
            f"{what}: {y.size} plateau(s) at {np.unique(np.round(dt, 6)).size} distinct "
            "temperature(s) cannot determine a temperature coefficient with its uncertainty; "
            "a thermal test needs at least 3 plateaus at distinct temperatures",
            parameter="order")
    chosen, tests = (top, ()) if order != "auto" else (1, [])
    if order == "auto":
        while chosen + 1 in fits:
            chi_a, chi_b, nu_b = fits[chosen][2], fits[chosen + 1][2], fits[chosen + 1][5]
            f = max(chi_a - chi_b, 0.0) / (chi_b / nu_b) if chi_b > 0 else np.inf  # Eq. (3)
            p = float(stats.f.sf(f, 1, nu_b))
            tests.append((chosen + 1, float(f), p))
            if p >= alpha:
                break
            chosen += 1
    coef, unscaled, chi2, resid, use_h, nu = fits[chosen]
    birge2 = chi2 / nu  # Birge ratio squared [Birge]
    scaled = birge2 > 1.0
    dof = nu if scaled or not weights_dof else int(weights_dof)
    return PolyFit(order=chosen, hysteresis=use_h, values=coef,
                   covariance=unscaled * max(birge2, 1.0), dof=dof, chi2=chi2,
                   fitted=y - resid, residuals=resid, tests=tuple(tests),
                   birge=float(np.sqrt(birge2)), residual_dof=nu)
