"""The noise fit's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The IEEE 952 coefficients (Q, N, B, K, R) and the mean are fitted to the
Allan variance of a still recording [IEEE952]_: each is proportional to the
recording's scale, so a relative gain error ``delta`` of the data
acquisition moves every coefficient by ``delta`` times itself (``c = y``
per relative gain, in closed form). Everything else the fit's Type A part
already holds.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [IEEE952] IEEE Std 952-1997, Annex C.
"""


def _gain(row, std) -> float:
    """Sensitivity of a coefficient to the DAQ's gain: ``y`` per relative gain."""
    return row.estimate * std.factor("1")


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` holding the closed-form gain (data unused)."""
    from accelcal.budget.engine import DataModel

    return DataModel(None, 0, "", analytic={"daq_gain": _gain})
