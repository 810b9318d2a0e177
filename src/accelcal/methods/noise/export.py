"""The fitted noise in the IMU noise file visual-inertial estimators read (Kalibr's imu.yaml).

Kalibr's continuous-time IMU noise model [Kalibr]_ has, per axis, a white
noise of density ``sigma_a`` and a bias random walk driven by white noise
of density ``sigma_ba``; they are the IEEE 952 N and K of the same sensor
[IEEE952]_ in SI units:

* ``accelerometer_noise_density`` = N in m/s^2/sqrt(Hz) (= m/s^2 sqrt(s));
* ``accelerometer_random_walk`` = K in m/s^3/sqrt(Hz) (= m/s^2/sqrt(s));
* ``update_rate`` = the record's sample rate, Hz (Kalibr discretises with it:
  ``sigma_d = sigma / sqrt(dt)`` for the white noise, ``sigma sqrt(dt)`` for
  the walk).

Two layouts: ``kalibr``, the flat imu.yaml of ``kalibr_calibrate_imu_camera``
(with ``rostopic``); ``ros``, the same keys under ``imu0:``, the IMU chain
file that ROS estimators such as OpenVINS read beside Kalibr's output. The
gyroscope keys are left as comments: they come from a gyroscope's own fit.

Values from an Allan analysis describe the sensor at rest on a quiet
table; Kalibr's documentation advises inflating them for an estimator
(vibration, temperature and other unmodelled effects), which the file says
in a comment without applying it.

References
----------
.. [Kalibr] Furgale P., Rehder J., Siegwart R., Unified temporal and spatial
   calibration for multi-sensor systems, IROS 2013; ethz-asl/kalibr wiki,
   "IMU Noise Model".
.. [IEEE952] IEEE Std 952-1997, Annex C.
"""

from accelcal.errors import AccelcalError

FORMATS = ("kalibr", "ros")
"""Export layouts."""


def noise_yaml(reduction, layout: str = "kalibr", rostopic: str = "/imu0") -> str:
    """The fitted N and K of a noise fit as Kalibr-convention YAML text.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
        A noise fit (family ``noise``) with N and K among its terms, of
        samples in g, mg, ug or m/s^2.
    layout : str
        ``kalibr`` (flat imu.yaml) or ``ros`` (under ``imu0:``).
    rostopic : str
        The IMU topic written.

    Returns
    -------
    str
        The YAML document, with the units, the fit's uncertainties and the
        inflation advice in comments.

    Raises
    ------
    AccelcalError
        Another layout (``export``), a fit without N or K (``terms``), or
        samples in a unit with no SI value (``unit``).
    """
    from accelcal.methods.noise.fit import coefficients
    from accelcal.units import STANDARD_GRAVITY

    if layout not in FORMATS:
        raise AccelcalError(f"{layout!r} is not one of {', '.join(FORMATS)}",
                            parameter="export")
    doc = coefficients(reduction)
    missing = [t for t in ("N", "K") if t not in doc]
    if missing:
        raise AccelcalError(f"the fit has no {' or '.join(missing)}: the noise file needs N and "
                            "K (fit with terms that include N and K)", parameter="terms")
    unit = doc["unit"]
    to_si = {"g": STANDARD_GRAVITY, "mg": 1e-3 * STANDARD_GRAVITY,
             "ug": 1e-6 * STANDARD_GRAVITY, "m/s^2": 1.0}.get(unit)
    if to_si is None:
        raise AccelcalError(f"samples in {unit!r} have no SI value: give the unit g, mg, ug or "
                            "m/s^2 (or a scale to one of them)", parameter="unit")
    n, k = doc["N"] * to_si, doc["K"] * to_si
    un, uk = doc["N_std"] * to_si, doc["K_std"] * to_si
    bound = "K" in doc["at_bound"]
    if bound:  # 0 is no random walk an estimator can use: the 1-sigma size the data allow
        k = uk
    rate = float(reduction.provenance["rate_hz"])
    pad = "  " if layout == "ros" else ""
    lines = [
        "# IMU noise of one accelerometer axis from accelcal's IEEE 952 fit (Kalibr's",
        "# continuous-time model: white noise density and bias random walk, SI units).",
        f"# Fit: N = {n:.6g} +/- {un:.2g} m/s^2/sqrt(Hz), K = "
        + (f"at its bound 0 (written: its 1-sigma bound {uk:.2g})" if bound else
           f"{k:.6g} +/- {uk:.2g}") + " m/s^3/sqrt(Hz);",
        f"# goodness of fit chi^2 = {doc.get('chi2', float('nan')):.3g} on "
        f"{doc.get('chi2_dof', 0)} dof"
        + ("" if doc.get("model_fits", True) else " (the model does NOT describe the record)")
        + ".",
        "# These are Allan-variance values of a sensor at rest. Kalibr's documentation advises",
        "# inflating them for an estimator (unmodelled vibration, temperature, axis effects);",
        "# a common choice is x5 to x10 on both. They are written here uninflated.",
    ]
    if layout == "ros":
        lines.append("imu0:")
    lines += [
        f"{pad}accelerometer_noise_density: {n:.6e}  # m/s^2/sqrt(Hz)",
        f"{pad}accelerometer_random_walk: {k:.6e}  # m/s^3/sqrt(Hz)",
        f"{pad}# gyroscope_noise_density: from the gyroscope's own fit, rad/s/sqrt(Hz)",
        f"{pad}# gyroscope_random_walk: from the gyroscope's own fit, rad/s^2/sqrt(Hz)",
        f"{pad}rostopic: {rostopic}",
        f"{pad}update_rate: {rate!r}  # Hz",
    ]
    return "\n".join(lines) + "\n"
