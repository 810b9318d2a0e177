"""The physics below rigs and methods: frames, positions, geometry, gravity.

What a sensor feels on each rig, written once, so that the rigs (which
simulate it) and the methods (which reduce records by it) both import it
and neither imports the other:

- :mod:`accelcal.physics.tumble`: specific force at the positions of a
  rotation about the output axis (OA) or the pendulum axis (PA, the
  indexing head of Dong2014), the tumble's design matrix and input checks;
- :mod:`accelcal.physics.centrifuge`: orientations of the input, output
  and pendulum axes on a centrifuge arm, small-angle misalignment, the
  specific force with the rig's radius and arm errors, and the model's
  regressors and gradients there;
- :mod:`accelcal.physics.gravity`: WGS84 normal gravity (Somigliana, with a
  free-air height term) and the accepted range of a local gravity value.
- :mod:`accelcal.physics.equation`: the error model's equation, the
  indicated acceleration of given specific force and coefficients, which
  :class:`~accelcal.model.ErrorModel` evaluates (adding its noise and scale
  factor);
- :mod:`accelcal.physics.response`: the force-rebalance accelerometer's
  transfer function (second order, an extra pole, a delay), which the
  comparison rig simulates and the response method fits.

This package imports only :mod:`accelcal.errors`, :mod:`accelcal.validation`,
:mod:`accelcal.units` and :mod:`accelcal.terms`, and nothing on import (its
modules are imported by name).

References
----------
.. [IEEE1293] IEEE Std 1293-2018, annex on multipoint tumble analysis.
.. [Dong2014] Dong C., Liu Q., Ren S., Test methods of four integrated
   accelerometers on an indexing head, 2014, eq. (5).
.. [TR8350.2] NIMA TR8350.2, Department of Defense World Geodetic System
   1984, 3rd ed., 2000, eq. (4-1).
.. [Guan2021] Guan W., Metrology & Measurement Technology 41(3), 2021, eqs. (1)-(3).
"""
