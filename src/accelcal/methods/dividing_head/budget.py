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
exact: the perturbed reduction shows it (its sensitivities are small).

Where the route fits ``Psi(beta) x`` linearly in the (normalised) outputs
(``single``, ``four``, and ``joint`` without autocollimator readings or
Gauss-Newton iterations), the perturbed reductions are not run again: each
perturbation becomes a change of every sensor's outputs and goes through
the reduction's first-order response
(:func:`~accelcal.methods.dividing_head.response.response`) --
the DAQ's gain ``dU = g U``, offset ``dU = o``, linearity ``dU = l |U| U /
max|U|``, and a position told ``delta`` further than it was, which is to
first order the data taken ``delta`` short of it, ``dU = -U'(beta)
delta``, ``U'`` the derivative of the sensor's fitted model ``Psi(beta) x``
[Dong2014]_ eq. (23) (the head's estimated angle errors and the residuals
enter at second order). The engine's central differences then run on this
linear model; the full re-run (``rerun=True``) is their check. The ``four``
route, which refuses positions not equally spaced, so gets the angle
inputs' sensitivities it could not get by a re-run. The ``tumble`` route
(IEEE 1293's Fourier model, not ``Psi``) is run again.

The inputs are listed in the method's descriptor
(:attr:`accelcal.catalog.Method.budget_inputs`).

References
----------
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014.
"""


def data_model(reduction, record, *, rerun: bool = False):
    """A :class:`~accelcal.budget.engine.DataModel` of a dividing-head record (None without one).

    ``record`` is the :class:`~accelcal.io.formats.dividing_head.HeadRecord`
    (or its file, or the :class:`HeadData`) the reduction was made from; the
    route is the reduction's. The perturbed reductions are the route's
    first-order response (:func:`linearised`) where it has one; ``rerun``:
    always the reduction run again on the perturbed data.
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

    def run_again(*, gain=0.0, offset=0.0, linearity=0.0, angles=None,
                  autocollimator=None):
        outputs = bowed(data.outputs * (1.0 + gain) + offset, linearity)
        positions = data.positions if angles is None else data.positions + angles
        opts = dict(options)
        if autocollimator is not None:
            opts["autocollimator"] = np.asarray(readings) + autocollimator
        return reduce(dataclasses.replace(data, outputs=outputs, positions=positions), route,
                      **opts, priors="none")

    vectors = {"autocollimator": "autocollimator"} if readings is not None else {}
    linear = None if rerun or readings is not None else linearised(data, route, options)
    return DataModel(linear or run_again, int(data.positions.size), data.output_unit, "PA",
                     vectors)


def linearised(data, route: str, options: dict):
    """The route's reduction of perturbed data to first order, or None where it has none.

    Parameters
    ----------
    data : HeadData
    route : str
        ``single``, ``four``, ``joint`` or ``tumble``.
    options : dict
        The route's options (a record's first harmonic, mean error, ...).

    Returns
    -------
    callable or None
        ``reduce(*, gain=0.0, offset=0.0, linearity=0.0, angles=None) ->
        Reduction``, as :class:`~accelcal.budget.engine.DataModel` takes it:
        the reduction of ``data`` with every sensor's coefficients moved by
        the response to the perturbation's output change (module doc).
        None for the ``tumble`` route and where the route has no linear
        response.
    """
    import dataclasses

    import numpy as np

    from accelcal.budget.engine import bowed
    from accelcal.methods.dividing_head import reduce
    from accelcal.methods.dividing_head.reduce import check_options
    from accelcal.methods.dividing_head.response import response

    if route == "tumble":  # its fitted model is not Psi(beta) x: the angles' slope differs
        return None
    base = reduce(data, route, **options, priors="none")
    apply = response(route, data, base, check_options(route, dict(options)))
    if apply is None:
        return None
    beta = data.angles()
    s, c = np.sin(beta), np.cos(beta)
    dpsi = np.stack([np.zeros_like(beta), c, -s, c * c - s * s, 2.0 * s * c], axis=-1)
    slope = np.einsum("knj,kj->kn", dpsi, np.array([e.values for e in base.sensors]))
    outputs = np.asarray(data.outputs, dtype=float)
    k = outputs.shape[0]

    def moved(*, gain=0.0, offset=0.0, linearity=0.0, angles=None):
        z = outputs * gain + offset + (bowed(outputs, linearity) - outputs)
        if angles is not None:
            z = z - slope * np.asarray(angles, dtype=float)[None, :]
        change = apply([(ell, z[ell]) for ell in range(k)]).sum(axis=1).reshape(k, 5)
        return dataclasses.replace(base, sensors=tuple(
            dataclasses.replace(e, values=e.values + d)
            for e, d in zip(base.sensors, change, strict=True)))

    return moved
