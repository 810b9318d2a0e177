"""The tumble's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The coefficients are the least-squares (or IEEE 1293 Fourier) solution of
the outputs ``E_j`` at the positions ``theta_j`` [IEEE1293]_. The lab's
inputs enter

- through the data: the DAQ's gain, offset and linearity act on ``E_j``
  (a current output read through a load resistor: ``V = I R``, a relative
  gain), each position's angle error on ``theta_j`` (head angle accuracy,
  or the autocollimator that reads the positions: one independent error
  per position);
- through the test's parameters: the local gravity (the 1 g of the
  positions), the tilt of the rotation axis from level;
- through the sensor's temperature coefficients: its temperature.

Sensitivities of the data inputs come from the reduction run again on the
perturbed record (:func:`accelcal.budget.engine.itemise`), always on the
least-squares route (the Fourier relations need exactly uniform positions
and give the same numbers where both apply).

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
"""


def data_model(reduction, record):
    """A :class:`~accelcal.budget.engine.DataModel` of a tumble record (None without one).

    ``record`` is the :class:`~accelcal.io.formats.tumble.TumbleRecord`
    (or its file) the reduction was made from.
    """
    if isinstance(record, list | tuple):  # the input files a calibration record names
        record = record[0] if record else None
    if record is None:
        return None
    import numpy as np

    from accelcal.budget.engine import DataModel, bowed
    from accelcal.methods.tumble import reduce_tumble

    if not hasattr(record, "angles_rad"):
        from accelcal.io.formats import tumble as tumble_format

        record = tumble_format.read(record)
    terms = reduction.provenance.get("terms")
    given = reduction.assumed("noise") == "given"
    sigma = reduction.assumed("noise_sd") if given else None
    repeats = record.repeats > 1
    base = record.outputs if repeats else record.outputs[:, 0]

    def rerun(*, gain=0.0, offset=0.0, linearity=0.0, angles=None):
        outputs = bowed(np.asarray(base) * (1.0 + gain) + offset, linearity)
        theta = record.angles_rad if angles is None else record.angles_rad + angles
        return reduce_tumble(theta, outputs, rotation_axis=record.rotation_axis,
                             output_unit=record.output_unit, terms=terms, route="lsq",
                             sigma=sigma, repeats=repeats, priors="none")

    return DataModel(rerun, int(record.angles_rad.size), record.output_unit,
                     record.rotation_axis)
