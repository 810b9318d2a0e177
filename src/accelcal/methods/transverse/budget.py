"""The transverse test's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The shaker vibrates the accelerometer in its transverse plane at an
amplitude ``A`` that the reference accelerometer measures (GuanTang, after
ISO 16063-31 [ISO16063-31]_); the first-order transverse sensitivities
(Ko, Kp) are the DUT's output at the vibration frequency over ``K1 A``, the
second-order ones (Koo, Kpp, Kop) its rectified and doubled-frequency
output over ``K1 A²``. A relative error ``delta`` of the reference's
sensitivity is a relative error ``delta`` of ``A``, so a coefficient of
order ``n`` in ``A`` moves by ``-n delta`` times itself: ``c = -n y`` per
relative sensitivity, in closed form.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [ISO16063-31] ISO 16063-31:2009, Testing of transverse vibration
   sensitivity.
"""

ORDER = {"transverse": 1, "misalignment": 1, "second": 2}
"""Power of the amplitude in the denominator of each kind of coefficient."""


def _reference(row, std) -> float:
    """Sensitivity of a coefficient to the reference's sensitivity, per lab unit."""
    per = std.factor("1") if std.dimension == "relative" else 1.0 / std.value
    return -ORDER.get(row.kind or "", 0) * row.estimate * per


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` holding the closed form (data unused)."""
    from accelcal.budget.engine import DataModel

    return DataModel(None, 0, "", analytic={"reference_sensitivity": _reference})
