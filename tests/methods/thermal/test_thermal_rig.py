"""The thermal-chamber rig and the thermal record format (issue 15 item 2).

The lag model is checked against the closed-form first-order step and ramp
responses [Ogata 5-3] (the rig runs the discretised first-order-hold
recursion), the settling time against ``tau ln(dT / tol)``, and the outputs
against the error model evaluated directly at the sensor temperature.
"""

import numpy as np
import pytest

from accelcal import ErrorModel
from accelcal.errors import AccelcalError
from accelcal.io.formats import thermal as thermal_format
from accelcal.methods.thermal import settling
from accelcal.methods.tumble import specific_force
from accelcal.rigs.thermal import Programme, lag, simulate
from accelcal.terms import TemperatureTerms

TAU, H = 600.0, 10.0


def test_lag_step_response_is_the_closed_form():
    # Step of 50 degC at t = 0 (the air jumps between samples 0 and 1: give the air at 50
    # from t = 0, sensor at 0): Ts = 50 (1 - exp(-t / tau)) [Ogata 5-3].
    t = np.arange(2000) * H
    ts = lag(np.full(t.size, 50.0), TAU, H, 0.0)
    # FOH is exact for an input linear between samples; rounding of a 2000-step recursion
    # stays within ~1e-12 degC on values of 50.
    np.testing.assert_allclose(ts, 50.0 * (1.0 - np.exp(-t / TAU)), rtol=0, atol=1e-11)


def test_lag_ramp_response_is_the_closed_form():
    # Air ramping at r from T_a, sensor starting at T_a: Ts = T_a + r (t - tau (1 - e^{-t/tau}))
    # [Ogata 5-3], then holding at the ramp's end value T_b from t1: Ts = T_b - (T_b - Ts(t1))
    # e^{-(t - t1)/tau}. The breakpoint falls on a sample (as in the rig), so FOH is exact.
    r, ta, n1 = 1.0 / 60.0, -40.0, 360
    t = np.arange(1500) * H
    t1 = n1 * H
    air = np.where(t <= t1, ta + r * t, ta + r * t1)
    ts = lag(air, TAU, H, ta)
    ramp = ta + r * (t - TAU * (1.0 - np.exp(-t / TAU)))
    end = ta + r * (t1 - TAU * (1.0 - np.exp(-t1 / TAU)))
    hold = air - (air - end) * np.exp(-(t - t1) / TAU)
    want = np.where(t <= t1, ramp, hold)
    np.testing.assert_allclose(ts, want, rtol=0, atol=1e-11)


def test_settling_time_is_tau_log_of_the_lag():
    # After a step dT the sensor is within tol of the final value from tau ln(dT / tol).
    t = np.arange(1, 4001) * 1.0
    dT, tol = 10.0, 0.1
    temp = 30.0 - dT * np.exp(-t / TAU)
    st = settling(t, temp, window=600.0, rate_limit=0.01, tolerance=tol)
    # the final value is the window's mean, 30 - ~1.4e-2 (not 30): solve with it
    want = TAU * np.log(dT / (tol + (30.0 - st.final))) + 1.0 - t[0]
    assert st.settling_time == pytest.approx(want, abs=1.0)  # one sample
    assert st.settled
    short = settling(t[:1200], temp[:1200], window=600.0, rate_limit=0.01, tolerance=tol)
    assert not short.settled
    # its rate is the LS slope of the exponential over the window (about dT/tau e^{-t/tau})
    assert short.rate == pytest.approx(dT / TAU * np.exp(-900.0 / TAU) * 60.0, rel=0.05)


MODEL = ErrorModel(K0=1e-4, K1=1.2, K2=1e-5, Kp=5e-5,
                   temperature=TemperatureTerms(25.0, {"K0_T1": 2e-6, "K1_T1": -3e-5,
                                                       "Kp_T1": 1e-7}))
PROG = Programme(setpoints=(-20.0, 40.0, 10.0), soak=1800.0, warmup=600.0, points=8, dwell=20.0)


def test_noise_free_outputs_are_the_models_at_the_sensor_temperature():
    rec = simulate(MODEL, PROG, noise=0.0, temperature_noise=0.0, hysteresis=1e-5,
                   hysteresis_scale=4e-6, rate_sensitivity=3e-5, warmup_amplitude=5e-5,
                   seed=1)
    s = np.r_[0, rec.directions()][rec.plateau + 1]  # hysteresis sign per row
    a = specific_force(rec.angle_rad, "OA")
    k1 = MODEL.terms_at(rec.temperature)["K1"] + 0.5 * s * 4e-6 * MODEL.K1
    # dT/dt from the air-minus-sensor difference (Eq. (1)), degC/min
    rate = (rec.chamber - rec.temperature) / TAU * 60.0
    want = k1 * (MODEL.output_g(*a, temperature=rec.temperature) + 0.5 * s * 1e-5
                 + 3e-5 * rate + 5e-5 * np.exp(-rec.t / 300.0))
    np.testing.assert_allclose(rec.output, want, rtol=1e-14, atol=1e-15)
    assert list(rec.directions()) == [-1, 1, -1]
    assert rec.rows("warm-up").size == 60
    angles, outputs, _ = rec.tumble(1)
    assert outputs.shape == (8, 2)
    np.testing.assert_allclose(angles, np.arange(8) * np.pi / 4)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_record_round_trip(tmp_path, suffix):
    rec = simulate(MODEL, PROG, seed=2)
    path = tmp_path / f"th{suffix}"
    thermal_format.write(path, rec)
    back = thermal_format.read(path)
    np.testing.assert_array_equal(back.output, rec.output)
    np.testing.assert_array_equal(back.temperature, rec.temperature)
    np.testing.assert_allclose(back.angle_rad, rec.angle_rad, rtol=0, atol=1e-15)
    assert back.setpoints == rec.setpoints
    assert back.metadata == rec.metadata
    assert ErrorModel.from_dict(back.metadata["true_model"]) == MODEL


@pytest.mark.parametrize(("kwargs", "parameter"), [
    ({"tau": -1.0}, "tau"), ({"noise": float("nan")}, "noise"),
    ({"hysteresis": 2.0}, "hysteresis")])
def test_rig_bad_settings(kwargs, parameter):
    with pytest.raises(AccelcalError) as exc:
        simulate(MODEL, PROG, **kwargs)
    assert exc.value.parameter == parameter


@pytest.mark.parametrize(("kwargs", "parameter"), [
    ({"soak": 15.0}, "soak"), ({"points": 0}, "points"), ({"step": 0.0}, "step"),
    ({"setpoints": (-300.0,)}, "temperature"), ({"ramp_rate": 0.0}, "ramp_rate")])
def test_programme_bad_settings(kwargs, parameter):
    with pytest.raises(AccelcalError) as exc:
        Programme(**kwargs)
    assert exc.value.parameter == parameter


def test_format_refuses_bad_columns(tmp_path):
    from accelcal.io.records import write_record

    meta = {"units": {"t": "s", "phase": "-", "plateau": "-", "angle": "deg", "output": "V",
                      "temperature": "degC"},
            "rotation_axis": "OA", "output_unit": "V", "setpoints_degC": [0.0], "start_degC": 25}
    cols = {"t": [1.0, 2.0], "phase": [2, 2], "plateau": [0, 3], "angle": [0.0, 90.0],
            "output": [1.0, 0.0], "temperature": [0.0, 0.0]}
    write_record(tmp_path / "b.csv", "thermal", meta, cols)
    with pytest.raises(AccelcalError, match="column plateau"):
        thermal_format.read(tmp_path / "b.csv")
    write_record(tmp_path / "c.csv", "thermal", meta, {**cols, "plateau": [0, 0],
                                                       "temperature": [0.0, -300.0]})
    with pytest.raises(AccelcalError, match="column temperature has a value outside"):
        thermal_format.read(tmp_path / "c.csv")
