"""Magnetic sensitivity: the output change per mT of a field along each axis (Helmholtz coils).

The coils step a uniform field B along the IA (x), PA (y) and OA (z) in
turn, one dwell per level (:mod:`accelcal.rigs.acceptance_env`). The dwell
means ``y_k`` (:mod:`~accelcal.methods.acceptance.dwells`, standard errors
``s_k`` from the noise pooled within the dwells) are fitted by weighted
least squares to

    y_k = c + K1 (m_x B_xk + m_y B_yk + m_z B_zk),

so each ``m_j`` (g/mT) is the least-squares slope of the output against
the field along axis j over K1, with the intercept shared. Covariance
``(X^T W X)^-1 / K1^2`` with ``W = diag(1 / s_k^2)``; its degrees of freedom
are those of the pooled noise (the fit is conditional on white noise
within the dwells and no drift between them; the weighted residual
chi-square across the dwells is given as a check: well above its dof it
says the dwells disagree beyond their noise). An axis along which no field
was applied is refused.

References
----------
.. [IEEE1293] IEEE Std 1293-2018, magnetic sensitivity.
.. [DOMAIN] accelcal domain notes, section 12.
"""

import numpy as np

from accelcal.errors import AccelcalError
from accelcal.methods.acceptance.dwells import dwell_means
from accelcal.methods.acceptance.steps import FAMILY
from accelcal.results import Assumption, Estimate, Reduction

METHOD = f"{FAMILY}/magnetic"
NAMES = ("m_x", "m_y", "m_z")
"""The sensitivity along the IA, PA, OA (g/mT)."""
AXIS_LABELS = {"m_x": "(x, IA)", "m_y": "(y, PA)", "m_z": "(z, OA)"}
"""Each sensitivity's axis, as the rows label it."""


def reduce_magnetic(record, *, settle: float = 0.0) -> Reduction:
    """Magnetic sensitivity per axis (module docs).

    Returns
    -------
    Reduction
        Family ``acceptance``, method ``acceptance/magnetic``; coefficients
        ``m_x, m_y, m_z`` (g/mT) with their covariance and the pooled
        noise's dof.

    Raises
    ------
    AccelcalError
        For a record that is not a magnetic test, or one that applies no
        field along an axis.
    """
    if record.test != "magnetic" or record.field is None:
        raise AccelcalError(f"a {record.test} record is not a magnetic test")
    dw = dwell_means(record, settle)
    edges = record.dwells()[:-1]
    field = record.field[edges]
    for j, name in enumerate(NAMES):
        if np.unique(field[:, j]).size < 2:
            axis = AXIS_LABELS[name][1:-1]
            raise AccelcalError(f"the record applies no field along axis {axis}: a magnetic "
                                "test steps the field along each of the three axes")
    k1 = record.scale_factor
    x = np.column_stack([np.ones(len(field)), field])
    w = 1.0 / dw.se**2
    cov_full = np.linalg.inv(x.T @ (x * w[:, None]))
    coef = cov_full @ (x.T @ (w * dw.mean))
    resid = dw.mean - x @ coef
    chi2 = float(np.sum(w * resid**2))
    values, cov = coef[1:] / k1, cov_full[1:, 1:] / k1**2
    est = Estimate(names=NAMES, values=values, covariance=cov,
                   units=dict.fromkeys(NAMES, "g/mT"), method=METHOD, dof=dw.dof)
    unit = record.output_unit
    return Reduction(
        family=FAMILY, method=METHOD, sensors=(est,), dof=dw.dof,
        assumptions=(
            Assumption("scale_factor", k1, f"{unit}/g", f"nominal scale factor {k1:g} {unit}/g"),
            Assumption("noise", "white", "", f"white output noise, {dw.sigma:.3g} {unit} per "
                       f"sample pooled over the dwells ({dw.dof} dof); no drift between dwells"),
            Assumption("settle", settle, "s", f"{settle:g} s dropped at the start of each dwell"),
        ),
        observations={"dwell_field": field, "dwell_mean": dw.mean, "dwell_se": dw.se,
                      "intercept": float(coef[0])},
        provenance={"test": "magnetic", "output_unit": unit, "scale_factor": k1,
                    "chi2": chi2, "chi2_dof": int(len(field) - 4)},
    )
