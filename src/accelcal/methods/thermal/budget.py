"""The thermal-chamber test's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The coefficients and their temperature coefficients come from a multipoint
tumble at each temperature plateau and polynomials in the sensor's
temperature ``T - T0`` fitted to the plateaus' coefficients [IEEE1293]_.
The lab's inputs enter

- through the temperature readings: the sensor-temperature measurement's
  error shifts every reading (a thermometer's calibration error, common to
  all plateaus), perturbed in the record and the reduction run again;
- through the data: the DAQ's gain, offset and linearity act on the
  outputs (a current output read through a load resistor, ``V = I R``, is
  a relative gain); each indexed position's angle error shifts that
  position at every plateau (one independent error per position);
- through the test's parameters: the local gravity (the 1 g of the
  tumbles, analytic as for the tumble), the tilt of the rotation axis.

The re-run uses the reduction's reference temperature and settings; the
polynomial orders are chosen again by the F-test, which steps of the
size of the inputs' uncertainties do not change.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, thermal sensitivity tests.
"""


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of a thermal record (None without one)."""
    if isinstance(records, list | tuple):  # the input files a calibration record names
        records = records[0] if records else None
    if records is None:
        return None
    import dataclasses

    import numpy as np

    from accelcal.budget.engine import DataModel, bowed
    from accelcal.io.formats import thermal as thermal_format
    from accelcal.methods.thermal import reduce

    record = records if hasattr(records, "temperature") else thermal_format.read(records)
    reference = reduction.provenance.get("reference_degC", 25.0)
    angles, index = np.unique(np.round(record.angle_rad, 9), return_inverse=True)

    def rerun(*, gain=0.0, offset=0.0, linearity=0.0, angles=None, temperature=0.0):
        shift = 0.0 if angles is None else np.asarray(angles)[index]
        rec = dataclasses.replace(
            record, output=bowed(np.asarray(record.output) * (1 + gain) + offset, linearity),
            angle_rad=record.angle_rad + shift, temperature=record.temperature + temperature)
        return reduce(rec, reference=reference, priors="none")

    return DataModel(rerun, int(angles.size), record.output_unit, record.rotation_axis,
                     parameters={"sensor_temperature": {"temperature": ("temperature", "degC")}})
