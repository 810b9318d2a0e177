"""The vibrafuge as a centrifuge plus a shaker (issue 14 item 5).

``accelcal.rigs.vibrafuge.simulate(..., centrifuge=rig)`` makes the sensor
feel the overload the centrifuge actually produces (radius error, stretch,
rate error, proof-mass offset, misalignment, gravity on the vertical) while
the run records the nominal overloads; without it nothing changes.
"""

import numpy as np
import pytest

from accelcal.defaults import default_model
from accelcal.errors import AccelcalError
from accelcal.rigs.centrifuge import CentrifugeRig
from accelcal.rigs.vibrafuge import simulate
from accelcal.units import STANDARD_GRAVITY as GN

ARGS = {"frequency": 50.0, "sample_rate": 5000.0, "duration": 0.2}


def test_default_is_unchanged():
    m = default_model()
    a = simulate(m, [1.0, 4.0], [5.0, 8.0], rng=np.random.default_rng(3), **ARGS)
    b = simulate(m, [1.0, 4.0], [5.0, 8.0], rng=np.random.default_rng(3), centrifuge=None,
                 **ARGS)
    np.testing.assert_array_equal(a.static, b.static)
    np.testing.assert_array_equal(a.vibrating, b.vibrating)


def test_overload_from_the_rig():
    # no errors: the nominal overload along IA plus gravity on PA (IA-in position)
    exact = CentrifugeRig(radius=1.2, gravity=9.80123).overload([[4.0, 0, 0], [-2.0, 0, 0]])
    np.testing.assert_allclose(exact, [[4.0, 0, 9.80123 / GN], [-2.0, 0, 9.80123 / GN]],
                               rtol=1e-14, atol=1e-15)
    # radius and rate errors scale it by (1 + e_R)(1 + e_w)^2; the stretch adds s Omega^2
    rig = CentrifugeRig(radius=1.2, radius_error=3e-4, rate_error=-1e-4, arm_stretch=1e-7)
    got = rig.overload([[4.0, 0, 0]])[0]
    w2 = 4.0 * GN / 1.2 * (1 - 1e-4) ** 2
    assert got[0] == pytest.approx(w2 * 1.2 * (1 + 3e-4 + 1e-7 * w2) / GN, rel=1e-13)


def test_vibrafuge_feels_the_centrifuge_errors():
    m = default_model().replace(sigma=0.0)
    rig = CentrifugeRig(radius=1.2, radius_error=5e-4)
    run = simulate(m, [2.0, 4.0], [5.0, 5.0], centrifuge=rig, noise=0.0, **ARGS)
    np.testing.assert_array_equal(run.overload[:, 0], [2.0, 4.0])  # nominal, as recorded
    felt = rig.overload(run.overload)
    want = m.output(felt[:, 0], felt[:, 1], felt[:, 2])
    np.testing.assert_allclose(run.static[:, 0], want, rtol=1e-13)
    plain = simulate(m, [2.0, 4.0], [5.0, 5.0], noise=0.0, **ARGS)
    # the overload error moves the static output by K1 b e_R (first order)
    shift = run.static[:, 0] - plain.static[:, 0] - m.K1 * (
        m.Kp * felt[:, 2] + m.Kpp * felt[:, 2] ** 2 + m.Kip * felt[:, 0] * felt[:, 2])
    np.testing.assert_allclose(shift, m.K1 * np.array([2.0, 4.0]) * 5e-4, rtol=2e-3)
    with pytest.raises(AccelcalError) as exc:
        simulate(m, [2.0], [5.0], centrifuge="fast", **ARGS)
    assert exc.value.parameter == "centrifuge"
