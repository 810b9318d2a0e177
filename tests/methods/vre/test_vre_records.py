"""Vibrafuge simulation and record reduction against the closed-form VRE (Guan2021)."""

import itertools
import json
from math import gcd

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from accelcal import AccelcalError, default_model
from accelcal.io.formats.vibrafuge import read_vibrafuge, write_vibrafuge
from accelcal.methods.vre import reduce_run, vector_vre
from accelcal.rigs.vibrafuge import point_sampling_bound, simulate

# Every term of the default model acts (K4 and the asymmetry made large so
# that a wrong term would show); the vibration direction is skew to the axes.
MODEL = default_model().replace(K4=2e-8, K0_asym=3e-5, K1_asym=-2e-5, sigma=0.0)
B = np.array([-4.0, -2.0, 0.0, 0.0, 1.0, 2.0, 3.0, 3.0, 4.0])
A = np.array([5.0, 1.0, 0.0, 3.0, 5.0, 2.0, 3.0, 7.0, 9.0])  # below, at and above |b|
DIRECTION = (0.9, 0.3, -0.2)


def _closed(model, run):
    return vector_vre(model, run.overload, run.amplitude, run.direction)[0]


def test_integrating_samples_are_bin_means_of_the_model():
    """Each integrating sample is the mean of ErrorModel.output_g over its interval (quad)."""
    run = simulate(MODEL, [[1.5, 0.4, -0.3]], [4.0], frequency=7.0, sample_rate=60.0,
                   duration=0.5, direction=DIRECTION, phase=0.3, noise=0.0)
    u, b = run.direction, run.overload[0]
    w = 2 * np.pi * 7.0

    def out(t):
        return float(MODEL.output(*(b + 4.0 * u * np.sin(w * t + 0.3))))

    dt = 1 / 60.0
    for j in range(run.static.shape[1]):
        t0 = j * dt
        # split at the sign changes of a_i so that quad integrates smooth pieces
        def ai(t):
            return b[0] + 4.0 * u[0] * np.sin(w * t + 0.3)

        grid = np.linspace(t0, t0 + dt, 201)
        change = np.flatnonzero(np.diff(np.sign(ai(grid))) != 0)
        cuts = [brentq(ai, grid[k], grid[k + 1], xtol=1e-18, rtol=1e-15) for k in change]
        edges = [t0, *cuts, t0 + dt]
        ref = sum(quad(out, lo, hi, epsabs=1e-16, epsrel=1e-13)[0]
                  for lo, hi in itertools.pairwise(edges)) / dt
        # outputs of ~2 V: rounding ~1e-15 V; 1e-13 V allows quad's error
        assert abs(run.vibrating[0, j] - ref) <= 1e-13, j


def test_noise_free_integrating_run_reduces_to_the_closed_form():
    """Simulation + whole-period reduction = closed form, with a partial last period,
    a non-zero start phase, overload vectors with b_i of both signs, and A
    below, at (b = A = 3) and above |b| along IA."""
    vectors = np.column_stack([B, np.full(B.size, 0.5), np.linspace(-1, 1, B.size)])
    for overload, direction in ((vectors, DIRECTION), (B, (1.0, 0.0, 0.0))):
        run = simulate(MODEL, overload, A, frequency=50.0, sample_rate=2000.0,
                       duration=0.2137, direction=direction, phase=1.234, noise=0.0)
        meas = reduce_run(run)
        assert meas.discarded > 0  # the record ends inside a period
        expected = _closed(MODEL, run)
        # Means of ~400 samples of up to ~13 V: rounding ~1e-15 V each; 1e-13 g
        # absolute leaves room for the summation, and is ~1e-9 of the VRE.
        np.testing.assert_allclose(meas.vre, expected, rtol=1e-12, atol=1e-13)
        assert np.abs(meas.vre - expected).max() < 1e-14  # as measured: ~1e-15 g


def test_point_sampling_error_is_within_its_stated_bound():
    """Instantaneous samples: the sgn term's discretisation error is below the bound,
    and the bound is not vacuous (the error is visible with few phases)."""
    f, fs = 49.0, 1000.0  # 1000 distinct phases (49/1000 in lowest terms)
    run = simulate(MODEL, B, A, frequency=f, sample_rate=fs, duration=1.0,
                   direction=DIRECTION, phase=0.7, noise=0.0, sampling="point")
    err = reduce_run(run).vre - _closed(MODEL, run)
    q = round(fs / gcd(int(f), int(fs)))
    bound = point_sampling_bound(MODEL, run, q)
    assert (np.abs(err) <= bound).all()
    # points with no sign change are exact (polynomial terms: q > 4)
    no_crossing = np.abs(run.amplitude * run.direction[0]) <= np.abs(run.overload[:, 0])
    assert np.abs(err[no_crossing]).max() < 1e-13
    coarse = simulate(MODEL, [1.0], [5.0], frequency=50.0, sample_rate=1000.0, duration=0.2,
                      noise=0.0, sampling="point")
    err_coarse = abs(reduce_run(coarse).vre[0] - _closed(MODEL, coarse)[0])
    assert 1e-9 < err_coarse <= point_sampling_bound(MODEL, coarse, 20)[0]


def test_noisy_reduction_agrees_within_its_uncertainty():
    """With white noise, (VRE - closed form) / u is standard normal over many points."""
    rng = np.random.default_rng(20210316)
    b = np.tile(B, 8)
    a = np.tile(A, 8)
    sigma = 2e-6
    run = simulate(MODEL, b, a, frequency=40.0, sample_rate=4000.0, duration=0.5,
                   direction=DIRECTION, phase=0.1, noise=sigma, rng=rng)
    meas = reduce_run(run)
    z = (meas.vre - _closed(MODEL, run)) / meas.uncertainty
    # u is the noise-derived standard uncertainty: sqrt(2) sigma / sqrt(n)
    np.testing.assert_allclose(meas.uncertainty, np.sqrt(2) * sigma / np.sqrt(2000), rtol=0.1)
    assert np.abs(z).max() < 4.5
    # 72 points: chi^2/72 lies in [0.6, 1.5] with probability > 0.999
    assert 0.6 < np.mean(z**2) < 1.5


def test_quantised_output_with_noise_stays_unbiased():
    """Quantisation with noise as dither: still within the noise-derived uncertainty."""
    rng = np.random.default_rng(7)
    run = simulate(MODEL, B, A, frequency=40.0, sample_rate=4000.0, duration=0.5,
                   direction=DIRECTION, noise=2e-6, quantum=2e-6, rng=rng)
    assert np.allclose(run.vibrating / 2e-6, np.round(run.vibrating / 2e-6))
    meas = reduce_run(run)
    z = (meas.vre - _closed(MODEL, run)) / meas.uncertainty
    assert np.abs(z).max() < 4.5


def test_record_file_round_trip(tmp_path):
    """Kind "vibrafuge" files keep every sample exactly and reduce identically."""
    rng = np.random.default_rng(3)
    run = simulate(MODEL, B[:4], A[:4], frequency=50.0, sample_rate=1000.0, duration=0.1,
                   direction=DIRECTION, phase=0.5, noise=1e-6, rng=rng)
    path = tmp_path / "run.csv"
    write_vibrafuge(path, run, provenance={"simulated_model": MODEL.terms()})
    back = read_vibrafuge(path)
    np.testing.assert_array_equal(back.static, run.static)
    np.testing.assert_array_equal(back.vibrating, run.vibrating)
    np.testing.assert_array_equal(back.overload, run.overload)
    np.testing.assert_allclose(back.direction, run.direction, rtol=1e-15)
    assert (back.sample_rate, back.frequency, back.scale_factor) == (1000.0, 50.0, MODEL.K1)
    np.testing.assert_array_equal(reduce_run(back).vre, reduce_run(run).vre)


def _edit(path, fn):
    lines = path.read_text().splitlines()
    lines = fn(lines)
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture
def record(tmp_path):
    run = simulate(MODEL, [1.0, 2.0], [5.0, 5.0], frequency=50.0, sample_rate=1000.0,
                   duration=0.05, noise=0.0)
    path = tmp_path / "r.csv"
    write_vibrafuge(path, run)
    return path


def _meta(lines):
    return json.loads(lines[1][2:])


def _with_meta(lines, **changes):
    meta = {**_meta(lines), **changes}
    return [lines[0], "# " + json.dumps(meta), *lines[2:]]


def test_unequal_sample_rates_are_refused(record):
    def stretch(lines):
        out = lines[:3]
        for k, line in enumerate(lines[3:]):
            cells = line.split(",")
            if k >= 50:  # the second point's time column at 990 Hz
                cells[1] = repr((k - 50) / 990.0)
            out.append(",".join(cells))
        return out

    _edit(record, stretch)
    with pytest.raises(AccelcalError, match="unequal sample rates: point 1"):
        read_vibrafuge(record)


def test_record_shorter_than_one_period_is_refused():
    run = simulate(MODEL, [1.0], [5.0], frequency=50.0, sample_rate=1000.0, duration=0.015,
                   noise=0.0)
    with pytest.raises(AccelcalError, match="shorter than one period"):
        reduce_run(run)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"points": [{"overload_g": [1, 0, 0], "amplitude_g": -5.0},
                     {"overload_g": [2, 0, 0], "amplitude_g": 5.0}]}, "negative"),
        ({"points": []}, "non-empty list"),
        ({"sample_rate_hz": "fast"}, "sample_rate_hz must be a finite number"),
        ({"scale_factor": 0}, "non-zero"),
        ({"direction": [0, 0, 0]}, "zero vector"),
        ({"direction": [1, 0]}, "3 finite numbers"),
        ({"points": [{"overload_g": [1, 0, 0], "amplitude_g": 5.0}]}, "column point"),
    ],
)
def test_bad_metadata_is_refused(record, change, message):
    _edit(record, lambda lines: _with_meta(lines, **change))
    with pytest.raises(AccelcalError, match=message):
        read_vibrafuge(record)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"amplitude": [-1.0]}, "negative"),
        ({"amplitude": [np.nan]}, "non-finite"),
        ({"frequency": 600.0}, "Nyquist"),
        ({"noise": 1e-6}, "random generator"),
        ({"sampling": "magic"}, "sampling"),
        ({"duration": 0.0}, "duration"),
        ({"overload": [], "amplitude": []}, "no test points"),
        ({"overload": [1.0, 2.0], "amplitude": [1.0, 2.0, 3.0]}, "do not match"),
    ],
)
def test_simulator_bad_input(kwargs, message):
    args = {"overload": [1.0], "amplitude": [5.0], "frequency": 50.0, "sample_rate": 1000.0,
            "duration": 0.1, **kwargs}
    with pytest.raises(AccelcalError, match=message):
        simulate(MODEL, args.pop("overload"), args.pop("amplitude"), **args)
