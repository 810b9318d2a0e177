"""The centrifuge's measurement model for uncertainty budgets (:mod:`accelcal.budget`).

The coefficients are the weighted least-squares solution of the step means
at the levels ``Omega^2 R / g`` in each position [IEEE836]_ (alone, or
jointly with a 1 g record). The lab's inputs enter

- through the test's parameters, each perturbed in the record and the
  reduction run again: the local gravity (the record's ``local_gravity``,
  which the reduction uses), the radius ``R`` from the spin axis to the
  sensor, the rate ``Omega`` (a relative error of every step's rate, or
  an absolute one in rad/s);
- through the data: the DAQ's gain, offset and linearity act on the
  outputs of every record (the same DAQ reads the 1 g record); a current
  output read through a load resistor (``V = I R``) is a relative gain;
- through the sensor's temperature coefficients: its temperature.

Where the reduction estimates the radius error (jointly with a 1 g record)
the radius input is absorbed by that estimate: its re-run sensitivity is
then small, as it should be.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [IEEE836] IEEE Std 836-2009, IEEE Recommended Practice for Precision
   Centrifuge Testing of Linear Accelerometers.
"""


def data_model(reduction, records):
    """A :class:`~accelcal.budget.engine.DataModel` of a centrifuge record (None without one).

    ``records`` is the centrifuge record (or its file), or the files a
    calibration record names (the centrifuge record, then the 1 g record
    of a joint reduction).
    """
    if records is None:
        return None
    import dataclasses

    import numpy as np

    from accelcal.budget.engine import DataModel, bowed
    from accelcal.io.formats import centrifuge as centrifuge_format
    from accelcal.methods.centrifuge import read_one_g, reduce_centrifuge, reduce_joint
    from accelcal.units import STANDARD_GRAVITY

    files = list(records) if isinstance(records, list | tuple) else [records]
    if not files:
        return None
    record = files[0]
    if not hasattr(record, "radius_m"):
        record = centrifuge_format.read(record)
    joint = reduction.method.endswith("joint")
    one_g = None
    if joint:
        if len(files) < 2:
            return None
        one_g = files[1] if hasattr(files[1], "outputs") else read_one_g(files[1])
    prov = reduction.provenance
    estimate = tuple(prov.get("estimated", ()))
    terms = prov.get("terms")
    gravity = float(record.metadata.get("local_gravity") or STANDARD_GRAVITY)

    def rerun(*, gain=0.0, offset=0.0, linearity=0.0, gravity_shift=0.0, radius=0.0, rate=0.0,
              rate_relative=0.0):
        meta = dict(record.metadata, local_gravity=gravity + gravity_shift)
        rec = dataclasses.replace(
            record, output=bowed(np.asarray(record.output) * (1 + gain) + offset, linearity),
            radius_m=record.radius_m + radius,
            rate=(np.asarray(record.rate) + rate) * (1 + rate_relative), metadata=meta)
        if not joint:
            return reduce_centrifuge(rec, terms=terms, estimate=estimate, priors="none")
        other = dataclasses.replace(
            one_g, outputs=bowed(np.asarray(one_g.outputs) * (1 + gain) + offset, linearity))
        return reduce_joint(rec, other, terms=terms, estimate=estimate, priors="none")

    return DataModel(rerun, 0, record.output_unit, parameters={
        "local_gravity": {"acceleration": ("gravity_shift", "m/s^2")},
        "centrifuge_radius": {"length": ("radius", "m")},
        "centrifuge_rate": {"rate": ("rate", "rad/s"), "relative": ("rate_relative", "1")}})
