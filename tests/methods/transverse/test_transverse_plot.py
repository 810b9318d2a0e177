"""Polar plots: GuanTang Fig. 4 reproduced, and the linear model's figure of eight beside it."""

import doctest

import numpy as np

import accelcal.signal.sinefit
from accelcal.methods import transverse as tr
from accelcal.methods.transverse.figures import figure4, polar_figure


def test_figure4_written_and_shows_the_papers_features(tmp_path):
    paths = figure4(tmp_path)
    assert [p.suffix for p in paths] == [".png", ".svg"]
    import matplotlib.image

    img = matplotlib.image.imread(paths[0])
    assert img.shape[0] > 800
    assert img.shape[1] > 1200
    ink = (img[..., :3] < 0.5).any(axis=-1).mean()
    assert 0.01 < ink < 0.5  # curves, grids and labels drawn, not blank
    # the data drawn: GuanTang Fig. 4 with the documented parameter set
    theta = np.deg2rad(np.arange(0.0, 360.0, 5.0))
    sweeps = tr.sweep(tr.GUANTANG_FIG4, (1.0, 5.0, 20.0, 50.0), theta, "peak")
    summary = [s.summary() for s in sweeps]
    # GuanTang section 4, inference 1: not a figure of eight, four local maxima,
    # minimum not zero; inference 2: it changes with the vibration amplitude
    assert [s["local_maxima"] for s in summary][1:] == [4, 4, 4]
    assert all(s["S_Tmin"] > 0.01 for s in summary)  # mV/g
    assert summary[3]["S_Tmax"] > 3 * summary[0]["S_Tmax"]
    # GuanTang eq. (25): s_I = 1000.055 mV/g for this parameter set
    assert abs(sweeps[0].s_I - 1000.055) < 1e-9


def test_polar_figure_panels():
    theta = np.deg2rad(np.arange(0.0, 360.0, 10.0))
    sweeps = tr.sweep(tr.GUANTANG_FIG4, (1.0, 5.0), theta, "fundamental")
    lin = tr.sweep(tr.figure4_linear(), (1.0,), theta, "fundamental")[0]
    fig = polar_figure(sweeps, linear=lin)
    # two amplitudes, the linear model, and the overlay of all amplitudes
    assert len(fig.axes) == 4
    # fundamental of the inertial model = linear model's figure of eight (DOMAIN section 3)
    np.testing.assert_allclose(sweeps[0].sT, lin.sT, rtol=0, atol=1e-12 * lin.sT.max())


def test_sinefit_docstring_examples():
    result = doctest.testmod(accelcal.signal.sinefit, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0
    assert result.failed == 0
