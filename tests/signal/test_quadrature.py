"""Heydemann's ellipse correction: the ellipse's parameters and the phase recovered."""

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.signal.quadrature import fit_ellipse, phase


@pytest.mark.parametrize("ellipse", [(0.0, 0.0, 1.0, 1.0, 0.0), (0.05, -0.03, 1.2, 0.8, 0.2),
                                     (-0.3, 0.4, 0.5, 0.7, -0.4)])
def test_ellipse_and_phase_recovered(ellipse):
    p, q, a, b, e = ellipse
    t = np.linspace(0.0, 0.05, 20000)
    phi = 30.0 * np.sin(2 * np.pi * 100 * t) + 0.7  # several fringes back and forth
    i_sig, q_sig = a * np.cos(phi) + p, b * np.sin(phi + e) + q
    fit = fit_ellipse(i_sig, q_sig)
    assert (fit.p, fit.q, fit.a, fit.b, fit.e) == pytest.approx(ellipse, abs=1e-9)
    got = phase(i_sig, q_sig, fit)
    assert np.max(np.abs(got - phi)) < 1e-9


def test_without_the_correction_the_phase_is_wrong():
    t = np.linspace(0.0, 0.05, 20000)
    phi = 30.0 * np.sin(2 * np.pi * 100 * t)
    i_sig, q_sig = 1.2 * np.cos(phi) + 0.05, 0.8 * np.sin(phi + 0.2)
    from accelcal.signal.quadrature import Ellipse

    plain = phase(i_sig, q_sig, Ellipse(0.0, 0.0, 1.0, 1.0, 0.0))
    assert np.max(np.abs(plain - phi)) > 0.05


def test_no_motion_refused():
    with pytest.raises(AccelcalError, match="no motion"):
        fit_ellipse(np.ones(100), np.ones(100))
    with pytest.raises(AccelcalError, match="ellipse"):
        fit_ellipse(np.arange(100.0), 2 * np.arange(100.0))  # a line
