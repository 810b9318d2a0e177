"""Centrifuge geometry and rig (issue 14 item 1), checked by independent routes.

The specific force of :mod:`accelcal.physics.centrifuge` (DOMAIN
section 9, in the rotating arm frame) and the revolution means of
:mod:`accelcal.rigs.centrifuge` (time-weighted quadrature over the phase)
are compared with a time-domain simulation in the rig's inertial frame: the
arm phase integrated from the rate ODE (scipy), the proof mass's position
differentiated twice numerically, gravity added, projected on the sensor's
turning axes and averaged over one period in time.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from accelcal.errors import AccelcalError
from accelcal.model import ErrorModel
from accelcal.physics.centrifuge import (
    POSITIONS,
    misaligned,
    orientation,
    position_matrix,
    specific_force,
)
from accelcal.rigs.centrifuge import CentrifugeRig
from accelcal.units import STANDARD_GRAVITY as GN

RIG = CentrifugeRig(radius=1.5, radius_error=3e-4, arm_stretch=2e-6, rate_error=-2e-4,
                    ripple=0.02, ripple_phase=0.7, tilt=0.01, tilt_azimuth=1.1,
                    proof_mass_offset=4e-3, gravity=9.80123)
"""Errors far beyond a real rig's, so that every term shows above the simulation's error."""


def test_positions_are_rotations_and_angles_build_them():
    for name, c in POSITIONS.items():
        np.testing.assert_array_equal(c @ c.T, np.eye(3), err_msg=name)
        assert np.linalg.det(c) == pytest.approx(1.0)
    np.testing.assert_array_equal(orientation((0, 0, 0)), POSITIONS["IA-in"])
    np.testing.assert_array_equal(orientation((180, 0, 0)), POSITIONS["IA-out"])
    np.testing.assert_array_equal(orientation((90, 0, 180)), POSITIONS["IA-tan"])
    c = orientation((12.0, -33.0, 71.0))
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-15)
    np.testing.assert_array_equal(position_matrix({"name": "x", "angles_deg": [180, 0, 0]}),
                                  POSITIONS["IA-out"])
    with pytest.raises(AccelcalError):
        position_matrix("IA-sideways")


def test_named_positions_feel_what_their_names_say():
    w = np.sqrt(20 * GN / 1.5)  # 20 g at 1.5 m
    got = {n: np.array(specific_force(c, w, 1.5)) for n, c in POSITIONS.items()}
    np.testing.assert_allclose(got["IA-in"], [20, 0, 1], rtol=1e-15)
    np.testing.assert_allclose(got["IA-out"], [-20, 0, 1], rtol=1e-15)
    np.testing.assert_allclose(got["OA-in"], [1, 20, 0], rtol=1e-15)
    np.testing.assert_allclose(got["OA-out"], [1, -20, 0], rtol=1e-15)
    np.testing.assert_allclose(got["PA-in"], [1, 0, 20], rtol=1e-15)
    np.testing.assert_allclose(got["PA-out"], [1, 0, -20], rtol=1e-15)
    np.testing.assert_allclose(got["IA-tan"], [0, 20, -1], rtol=1e-15)


def _inertial(rig, c_true, w_recorded, times_per_period=4000):
    """Time-domain simulation in the rig's inertial frame over one revolution.

    Returns the time grid's specific force (3, N) in sensor axes, in g.
    """
    w_true = w_recorded * (1 + rig.rate_error)
    shape_mean = np.mean(1 / (1 + rig.ripple * np.cos(np.linspace(0, 2 * np.pi, 4096,
                                                                  endpoint=False)
                                                      - rig.ripple_phase)))
    omega0 = w_true * shape_mean

    def rate(phi):
        return omega0 * (1 + rig.ripple * np.cos(phi - rig.ripple_phase))

    sol = solve_ivp(lambda t, y: [rate(y[0])], (0, 2.0 * 2 * np.pi / w_true), [0.0],
                    dense_output=True, rtol=1e-13, atol=1e-13,
                    events=lambda t, y: y[0] - 2 * np.pi)
    period = sol.t_events[0][0]
    t = np.arange(times_per_period) * period / times_per_period
    h = 1e-4 * period  # central second difference: error ~ h^2 Omega^4 R / 12, 1e-8 relative

    def position(tt):
        phi = sol.sol(tt)[0]
        e_r, e_t = np.array([np.cos(phi), np.sin(phi), 0 * phi]), \
            np.array([-np.sin(phi), np.cos(phi), 0 * phi])
        i_arm = c_true[0]  # IA in arm coordinates (r inward, t, z)
        big_r = rig.radius * (1 + rig.radius_error + rig.arm_stretch * rate(phi) ** 2)
        x = big_r - rig.proof_mass_offset * i_arm[0]
        y = rig.proof_mass_offset * i_arm[1]
        z = rig.proof_mass_offset * i_arm[2]
        return x * e_r + y * e_t + np.array([0, 0, 1.0])[:, None] * z, phi, e_r, e_t

    p_plus, p0, p_minus = position(t + h)[0], position(t), position(t - h)[0]
    acc = (p_plus - 2 * p0[0] + p_minus) / h**2
    up = np.array([np.sin(rig.tilt) * np.cos(rig.tilt_azimuth),
                   np.sin(rig.tilt) * np.sin(rig.tilt_azimuth), np.cos(rig.tilt)])
    f = acc + rig.gravity * up[:, None]
    _, _, e_r, e_t = p0
    # sensor axes in the rig frame: arm coordinates (r = -e_R, t, z)
    axes = [row[0] * -e_r + row[1] * e_t + row[2] * np.array([0, 0, 1.0])[:, None]
            for row in c_true]
    return np.array([np.sum(ax * f, axis=0) for ax in axes]) / GN, (p0[1], omega0)


@pytest.mark.parametrize("name", ["IA-in", "OA-out", "IA-tan"])
def test_revolution_mean_matches_an_inertial_time_domain_simulation(name):
    c_true = misaligned(POSITIONS[name], (2e-3, -1e-3, 3e-3))
    rig = CentrifugeRig(**{**RIG.to_dict(), "misalignment": {name: (2e-3, -1e-3, 3e-3)}})
    w = np.sqrt(30 * GN / rig.radius)
    a_t, _ = _inertial(rig, c_true, w)
    # The central second difference at h = 1e-4 T errs by (Omega h)^2 / 12 ~ 3e-8 of the
    # 30 g input (1e-6 g); the stretch following the ripple (d2X/dt2, 2 Omega dX/dt), which
    # the quasi-static arm formula leaves out, is below 1e-7 g. Tolerance 3e-6 g: a radius
    # error of 3e-4 alone moves the radial mean by 1e-2 g.
    for axis in range(3):
        got = rig.revolution_mean(_Axis(axis), c_true[None], np.array([w]))[0]
        assert got == pytest.approx(np.mean(a_t[axis]), abs=3e-6), (name, axis)
    # A nonlinear model's output averaged in time. The rig takes the stretch as quasi-static:
    # with this (exaggerated) stretch and ripple, X oscillates with d2X/dt2 ~ R s Omega^4 2 rho
    # ~ 5e-4 g, which averages out of the linear means above but leaves ~1e-5 g through K3
    # (a real rig: s ~ 1e-9 s^2, rho ~ 1e-4, ~1e-12 g). So: without stretch, to the finite
    # differences' 1e-6 g times dU/da_i ~ 0.5 (tolerance 2e-6 g).
    rig = CentrifugeRig(**{**rig.to_dict(), "arm_stretch": 0.0})
    a_t, _ = _inertial(rig, c_true, w)
    m = ErrorModel(K1=1.0, K2=1e-3, K3=-2e-4, Kio=5e-4, Kop=-3e-4, Kpp=2e-4, output_unit="g")
    got = rig.revolution_mean(m, c_true[None], np.array([w]))[0]
    assert got == pytest.approx(np.mean(m.output_g(*a_t)), abs=2e-6)


class _Axis:
    """Model stand-in: the output is one component of the specific force."""

    def __init__(self, axis):
        self.axis = axis

    def output_g(self, a_i, a_o, a_p):
        return (a_i, a_o, a_p)[self.axis]


def test_instantaneous_force_matches_the_inertial_simulation():
    # no stretch: the arm formula (9.2) is then exact at every instant, ripple and tilt included
    rig = CentrifugeRig(radius=1.5, ripple=0.02, ripple_phase=0.3, tilt=0.01, tilt_azimuth=1.1,
                        proof_mass_offset=4e-3)
    c = misaligned(POSITIONS["IA-tan"], (1e-3, 2e-3, -1e-3))
    w = np.sqrt(30 * GN / rig.radius)
    a_t, (phi, omega0) = _inertial(rig, c, w, times_per_period=50)
    shape = 1 + rig.ripple * np.cos(phi - rig.ripple_phase)
    omega = omega0 * shape
    omega_dot = -omega0 * rig.ripple * np.sin(phi - rig.ripple_phase) * omega
    up = np.stack([-np.sin(rig.tilt) * np.cos(phi - rig.tilt_azimuth),
                   -np.sin(rig.tilt) * np.sin(phi - rig.tilt_azimuth),
                   np.full(phi.size, np.cos(rig.tilt))], axis=-1)
    want = specific_force(c[None], omega, rig.radius, gravity=rig.gravity,
                          proof_mass_offset=rig.proof_mass_offset, rate_dot=omega_dot, up=up)
    # finite differences: ~1e-8 of the 30 g input
    np.testing.assert_allclose(a_t, np.array(want), rtol=0, atol=2e-6)


def test_tilt_and_ripple_average_out_to_first_order():
    w = np.sqrt(40 * GN / 1.5)
    c = POSITIONS["IA-in"][None]
    lin = _Axis(0)
    base = CentrifugeRig(radius=1.5).revolution_mean(lin, c, np.array([w]))[0]
    assert base == pytest.approx(40.0, rel=1e-14)
    tau = 1e-2
    tilted = CentrifugeRig(radius=1.5, tilt=tau, tilt_azimuth=0.4)
    # first order: the tilt's gravity turns once per revolution in the arm frame: mean 0
    assert tilted.revolution_mean(lin, c, np.array([w]))[0] == pytest.approx(40.0, rel=1e-14)
    # second order: K2 sees the mean square (g sin tau)^2 / 2 on IA
    m = ErrorModel(K1=1.0, K2=1e-3, output_unit="g")
    d = tilted.revolution_mean(m, c, np.array([w]))[0] - \
        CentrifugeRig(radius=1.5).revolution_mean(m, c, np.array([w]))[0]
    assert d == pytest.approx(1e-3 * np.sin(tau) ** 2 / 2, rel=1e-9)
    # ripple rho: the time mean of Omega^2 over a revolution of mean rate Omega is
    # Omega^2 / sqrt(1 - rho^2) = Omega^2 (1 + rho^2 / 2 + ...), the tangential R dOmega/dt
    # averages to zero
    rho = 0.05
    rippled = CentrifugeRig(radius=1.5, ripple=rho, ripple_phase=2.0)
    got = rippled.revolution_mean(lin, c, np.array([w]))[0]
    assert got == pytest.approx(40.0 / np.sqrt(1 - rho**2), rel=1e-13)
    tan = rippled.revolution_mean(_Axis(1), c, np.array([w]))[0]
    assert abs(tan) < 1e-12


def test_rig_refuses_bad_errors():
    for kwargs, parameter in (({"radius": 0.0}, "radius"), ({"tilt": 0.5}, "tilt"),
                              ({"gravity": 1.0}, "gravity"),
                              ({"radius_error": float("nan")}, "radius_error"),
                              ({"misalignment": {"IA-in": (1.0, 0, 0)}}, "misalignment")):
        with pytest.raises(AccelcalError) as exc:
            CentrifugeRig(**kwargs)
        assert exc.value.parameter == parameter
