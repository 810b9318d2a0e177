"""The indexing head's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The coefficients (Dong2014's K_F, K_I, K_O, K_IO, K_II per sensor, and the
head's separated angle errors) are solved from the four sensors' outputs at
the head's positions [Dong2014]_. The lab's inputs enter

- through the data: the DAQ's gain, offset and linearity act on every
  sensor's outputs; a current output read through a load resistor
  (``V = I R``) is a relative gain; each position's angle error (the head's
  angle accuracy: one independent error per position) shifts that position;
  the autocollimator's error shifts its reading of each position where the
  reduction uses the readings (the joint route with a record's
  ``autocollimator_arcsec``), else the position itself;
- through the test's parameters: local gravity, the tilt of the head's axis
  (gravity along PA, the head's axis);
- through the sensor's temperature coefficients: its temperature.

A reduction that separates the head's angle errors (four-sensor and joint
routes) is insensitive to them to first order where the separation is
exact: the re-run reduction shows it (its sensitivities are small).

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
"""


def data_model(reduction, record):
    """A :class:`~accelcal.budget.engine.DataModel` of a dividing-head record (None without one).

    ``record`` is the :class:`~accelcal.io.formats.dividing_head.HeadRecord`
    (or its file, or the :class:`HeadData`) the reduction was made from; the
    route is the reduction's.
    """
    if isinstance(record, list | tuple):  # the input files a calibration record names
        record = record[0] if record else None
    if record is None:
        return None
    import dataclasses

    import numpy as np

    from accelcal.budget.engine import DataModel, bowed
    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.method_ids import route_of
    from accelcal.methods.dividing_head import HeadData, options_from_record, reduce

    route = route_of(reduction.method)
    if isinstance(record, HeadData):  # the data alone: no record's autocollimator or harmonic
        data, options = record, {}
    else:
        if not hasattr(record, "mounts"):
            record = read_head_record(record)
        data, options = HeadData.from_record(record), options_from_record(record, route)
    readings = options.get("autocollimator")

    def rerun(*, gain=0.0, offset=0.0, linearity=0.0, angles=None, autocollimator=None):
        outputs = bowed(data.outputs * (1.0 + gain) + offset, linearity)
        positions = data.positions if angles is None else data.positions + angles
        opts = dict(options)
        if autocollimator is not None:
            opts["autocollimator"] = np.asarray(readings) + autocollimator
        return reduce(dataclasses.replace(data, outputs=outputs, positions=positions), route,
                      **opts, priors="none")

    vectors = {"autocollimator": "autocollimator"} if readings is not None else {}
    return DataModel(rerun, int(data.positions.size), data.output_unit, "PA", vectors)
