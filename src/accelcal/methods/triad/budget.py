"""The triad calibration's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

A triad's scale factors, biases and non-orthogonality angles come from the
static positions' mean readings against the local gravity vector (known
orientations) or its norm (unknown orientations) [Tedaldi2014]_. The lab's
input here is the local gravity the calibration is referred to: perturbed
and the calibration run again from the recording (the same route,
detection and estimator). The triad's readings are counts of its own
converter: a DAQ's inputs do not apply.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [Tedaldi2014] Tedaldi D., Pretto A., Menegatti E., A robust and easy to
   implement method for IMU calibration without external equipments, ICRA
   2014.
"""


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of a triad recording (None without one)."""
    if isinstance(records, list | tuple):  # the input files a calibration record names
        records = records[0] if records else None
    if records is None:
        return None
    from accelcal.budget.engine import DataModel
    from accelcal.methods.triad.lab import run

    gravity = float(reduction.assumed("gravity"))
    route = "known" if "known" in reduction.method else "unknown"

    def rerun(*, gravity_shift=0.0):
        return run(records, orientations=route, gravity=gravity + gravity_shift).reduction

    return DataModel(rerun, 0, "counts",
                     parameters={"local_gravity": {"acceleration": ("gravity_shift", "m/s^2")}})
