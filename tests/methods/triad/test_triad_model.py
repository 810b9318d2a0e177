"""The triad model (issue 12): T K, quadratic terms, files, imucal, the body frame, gravity.

Independent routes: the model written out component by component; imucal's
own ``FerrarisCalibrationInfo._calibrate_acc``; a triad built from its
physical sensor axes (readings are projections n_i·a); the closed form of
WGS84 normal gravity in terms of the semi-axes.
"""

import json

import numpy as np
import pytest

from accelcal.errors import AccelcalError
from accelcal.methods.triad import PARAMS, QUADRATIC, TriadCalibration, calibrate_known
from accelcal.methods.triad.frames import angles_of, t_matrix
from accelcal.physics.gravity import GAMMA_E, GAMMA_P, normal_gravity

G = 9.80665
SIX = np.vstack([np.eye(3), -np.eye(3)])


def random_cal(rng, unit="m/s^2", quadratic=False):
    if unit == "counts":
        bias, scale = rng.uniform(-500, 500, 3), rng.uniform(5e-4, 7e-4, 3)
    else:
        bias, scale = rng.uniform(-0.2, 0.2, 3), rng.uniform(0.97, 1.03, 3)
    q = rng.uniform(-1e-4, 1e-4, 3) if quadratic else None
    return TriadCalibration(bias, scale, rng.uniform(-3e-3, 3e-3, 3), q, unit)


# ------------------------------------------------------------------------- the model
def test_apply_is_the_model_written_out():
    rng = np.random.default_rng(1)
    cal = random_cal(rng, quadratic=True)
    u = rng.normal(0, 10, (50, 3))
    (bx, by, bz), (sx, sy, sz), (ayz, azy, azx) = cal.bias, cal.scale, cal.angles
    qx, qy, qz = cal.quadratic
    px, py, pz = sx * (u[:, 0] - bx), sy * (u[:, 1] - by), sz * (u[:, 2] - bz)
    wx, wy, wz = px + qx * px**2, py + qy * py**2, pz + qz * pz**2
    want = np.column_stack([wx - ayz * wy + azy * wz, wy - azx * wz, wz])
    np.testing.assert_allclose(cal.apply(u), want, rtol=1e-14, atol=1e-13)
    np.testing.assert_allclose(cal.apply(u[3]), want[3], rtol=1e-14, atol=1e-13)
    lin = TriadCalibration(cal.bias, cal.scale, cal.angles)
    np.testing.assert_allclose(lin.apply(u), (u - cal.bias) @ lin.matrix.T, rtol=1e-14,
                               atol=1e-13)
    assert np.allclose(lin.matrix, t_matrix(cal.angles) @ np.diag(cal.scale), rtol=0, atol=0)
    np.testing.assert_array_equal(angles_of(t_matrix(cal.angles)), cal.angles)
    assert cal.vector.tolist() == [*cal.bias, *cal.scale, *cal.angles, *cal.quadratic]
    assert len(PARAMS) == 9
    assert len(QUADRATIC) == 3


@pytest.mark.parametrize("quadratic", [False, True])
def test_readings_invert_apply(quadratic):
    rng = np.random.default_rng(2)
    cal = random_cal(rng, "counts", quadratic)
    a = rng.normal(0, 15, (200, 3))
    u = cal.readings(a)
    # rounding of ~1e4-count outputs (eps 2e-12 counts) times s ~ 6e-4 and |a| ~ 15
    np.testing.assert_allclose(cal.apply(u), a, rtol=0, atol=1e-11)
    rot = TriadCalibration(cal.bias, cal.scale, cal.angles, cal.quadratic, "counts",
                           _rotation(rng))
    np.testing.assert_allclose(rot.apply(rot.readings(a, frame="reference"), frame="reference"),
                               a, rtol=0, atol=1e-11)
    np.testing.assert_allclose(rot.apply(u, frame="reference"), a @ rot.rotation.T, atol=1e-11)


def _rotation(rng) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.random(random_state=rng.integers(1 << 30)).as_matrix()


@pytest.mark.parametrize(
    ("kwargs", "parameter"),
    [({"bias": [1, 2]}, "bias"), ({"scale": [1, 0, 1]}, "scale"),
     ({"angles": [0, 0.6, 0]}, "angles"), ({"angles": [0, np.nan, 0]}, "angles"),
     ({"input_unit": "furlong"}, "input_unit"), ({"quadratic": "abc"}, "quadratic"),
     ({"rotation": np.diag([1.0, 1.0, -1.0])}, "rotation")])
def test_bad_calibration(kwargs, parameter):
    args = {"bias": [0, 0, 0], "scale": [1, 1, 1], "angles": [0, 0, 0], **kwargs}
    with pytest.raises(AccelcalError) as exc:
        TriadCalibration(**args)
    assert exc.value.parameter == parameter
    assert "\n" not in str(exc.value)


# ------------------------------------------------------------------------------ files
def test_json_round_trip_and_save_load(tmp_path):
    rng = np.random.default_rng(3)
    for cal in (random_cal(rng), random_cal(rng, "counts", True)):
        back = TriadCalibration.from_dict(json.loads(cal.to_json()))
        np.testing.assert_array_equal(back.vector, cal.vector)
        assert back.input_unit == cal.input_unit
        path = tmp_path / "cal.json"
        cal.save(path)
        loaded = TriadCalibration.load(path)
        np.testing.assert_array_equal(loaded.vector, cal.vector)
        assert (loaded.quadratic is None) == (cal.quadratic is None)
    withrot = TriadCalibration([0, 0, 0], [1, 1, 1], [0, 0, 0], rotation=_rotation(rng))
    withrot.save(path)
    np.testing.assert_array_equal(TriadCalibration.load(path).rotation, withrot.rotation)


def _params_text(s_z: str) -> str:
    return ('{"format": "accelcal-triad-calibration", "format_version": 1, "parameters": '
            '{"b_x": 0, "b_y": 0, "b_z": 0, "s_x": 1, "s_y": 1, "s_z": ' + s_z
            + ', "a_yz": 0, "a_zy": 0, "a_zx": 0}}')


@pytest.mark.parametrize(
    ("text", "match"),
    [("not json", "triad calibration"), ('{"format": "other"}', "not an accelcal triad"),
     ('{"format": "accelcal-triad-calibration", "format_version": 9}', "format_version 9"),
     ('{"format": "accelcal-triad-calibration", "format_version": 1, "parameters": {}}',
      "lack b_x"),
     (_params_text('"x"'), "s_z must be a number"),
     (_params_text("0"), "scale factors must be non-zero")])
def test_load_refuses_bad_files(tmp_path, text, match):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(AccelcalError, match=match) as exc:
        TriadCalibration.load(path)
    assert "\n" not in str(exc.value)
    with pytest.raises(AccelcalError, match="cannot read"):
        TriadCalibration.load(tmp_path / "missing.json")


# ----------------------------------------------------------------------------- imucal
def _imucal_acc(layout, u):
    from imucal import FerrarisCalibrationInfo

    info = FerrarisCalibrationInfo(K_a=np.array(layout["K_a"]), R_a=np.array(layout["R_a"]),
                                   b_a=np.array(layout["b_a"]))
    return info._calibrate_acc(u)


def test_to_imucal_matches_imucal_formula():
    rng = np.random.default_rng(4)
    cal = random_cal(rng, "counts")
    u = cal.readings(rng.normal(0, 10, (300, 3)))
    ours, theirs = cal.apply(u), _imucal_acc(cal.to_imucal(), u)
    np.testing.assert_allclose(theirs, ours, rtol=1e-12, atol=1e-12 * np.abs(ours).max())
    layout = cal.to_imucal()
    # imucal's own Ferraris layout: unit rows of R_a, diagonal K_a
    np.testing.assert_allclose(np.linalg.norm(layout["R_a"], axis=1), 1.0, rtol=1e-15)
    assert np.count_nonzero(np.array(layout["K_a"]) - np.diag(np.diag(layout["K_a"]))) == 0
    with pytest.raises(AccelcalError, match="quadratic"):
        random_cal(rng, quadratic=True).to_imucal()


def test_from_imucal_general_rotation_is_exact_and_the_rotation_is_the_gauge():
    rng = np.random.default_rng(5)
    true = random_cal(rng)
    rot = _rotation(rng)
    # imucal calibration of a triad mounted rotated: acc_ref = rot T K (u - b)
    m_inv = np.linalg.inv(rot @ true.matrix)
    k = np.linalg.norm(m_inv, axis=1)
    layout = {"K_a": np.diag(k), "R_a": m_inv / k[:, None], "b_a": true.bias, "extra": 1}
    cal = TriadCalibration.from_imucal(layout)
    u = rng.normal(0, 10, (300, 3))
    want = _imucal_acc(layout, u)
    np.testing.assert_allclose(cal.apply(u, frame="reference"), want, rtol=1e-12,
                               atol=1e-12 * np.abs(want).max())
    np.testing.assert_allclose(cal.vector, true.vector, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(cal.rotation, rot, atol=1e-13)
    np.testing.assert_allclose(cal.apply(u), true.apply(u), atol=1e-12)
    again = cal.to_imucal()
    np.testing.assert_allclose(_imucal_acc(again, u), want, rtol=1e-12,
                               atol=1e-12 * np.abs(want).max())
    # a non-normalised R_a (any K_a R_a with the same product) reads the same
    d = np.diag([2.0, 0.5, 3.0])
    other = TriadCalibration.from_imucal({"K_a": layout["K_a"] @ d,
                                          "R_a": np.linalg.inv(d) @ layout["R_a"],
                                          "b_a": true.bias})
    np.testing.assert_allclose(other.vector, cal.vector, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("layout", [{"K_a": np.eye(3), "R_a": np.eye(3)},
                                    {"K_a": np.eye(2), "R_a": np.eye(3), "b_a": [0, 0, 0]},
                                    {"K_a": np.zeros((3, 3)), "R_a": np.eye(3), "b_a": [0, 0, 0]},
                                    [1, 2, 3]])
def test_from_imucal_refuses_bad_layouts(layout):
    with pytest.raises(AccelcalError) as exc:
        TriadCalibration.from_imucal(layout)
    assert exc.value.parameter == "data"


# ------------------------------------------------------------- the body frame (gauge)
def _triad_from_axes(axes, sens, bias):
    """Readings of a triad whose unit sensor axes (rows) are ``axes``: u_i = b_i + n_i·a / σ_i."""
    return lambda a: bias + (a @ axes.T) / sens


def _unit_rows(m):
    return m / np.linalg.norm(m, axis=1, keepdims=True)


@pytest.mark.parametrize(("case", "aligned"), [("upper", True), ("z tilted", False),
                                                ("y has x", False), ("lower", False)])
def test_body_frame_of_the_upper_triangular_t(case, aligned):
    """T upper triangular <=> n_z along z_body and n_y perpendicular to x_body.

    Readings u = b + diag(1/σ) N a with N = D U (D the diagonal of N, U unit
    upper triangular) give a = U^-1 diag(σ/D) (u - b): T = U^-1 and s = σ / n_ii.
    A known-orientation calibration in the body frame then finds the gauge
    rotation to be the identity exactly when N is upper triangular.
    """
    e = 2e-3
    n = {"upper": [[1, e, -e], [0, 1, 2 * e], [0, 0, 1]],
         "z tilted": [[1, e, -e], [0, 1, 2 * e], [e, 0, 1]],
         "y has x": [[1, e, -e], [e, 1, 2 * e], [0, 0, 1]],
         "lower": [[1, 0, 0], [e, 1, 0], [-e, 2 * e, 1]]}[case]
    axes = _unit_rows(np.array(n, dtype=float))
    sens = np.array([1.01, 0.99, 1.002])
    bias = np.array([0.1, -0.05, 0.02])
    read = _triad_from_axes(axes, sens, bias)
    up = np.vstack([SIX, _unit_rows(np.random.default_rng(6).normal(size=(6, 3)))])
    red = calibrate_known(read(G * up), up, G)
    rot = np.abs(red.shared.values).max()
    if aligned:
        assert rot < 1e-14
        cal = TriadCalibration.from_vector(red.estimate.values)
        np.testing.assert_allclose(np.linalg.inv(cal.t), axes / np.diag(axes)[:, None],
                                   rtol=0, atol=1e-14)
        np.testing.assert_allclose(cal.scale, sens / np.diag(axes), rtol=1e-14)
    else:
        assert rot > 1e-4  # the frame turns by an angle of the order of e
    # whatever the axes, the calibrated specific force is exact in the reference frame
    cal = TriadCalibration.from_vector(red.estimate.values, rotation=red.observations["rotation"])
    a = np.random.default_rng(7).normal(0, 9, (20, 3))
    np.testing.assert_allclose(cal.apply(read(a), frame="reference"), a, atol=1e-12)


# ---------------------------------------------------------------------------- gravity
def test_normal_gravity_published_values_and_closed_form():
    # TR8350.2 table 3.4: equatorial and polar normal gravity
    assert normal_gravity(0.0) == pytest.approx(9.7803253359, abs=1e-12)
    assert normal_gravity(90.0) == pytest.approx(9.8321849378, abs=1e-9)
    assert normal_gravity(-90.0) == normal_gravity(90.0)
    # Independent route: Somigliana in terms of the semi-axes a, b (TR8350.2 eq. 4-1, first form)
    a, b = 6378137.0, 6356752.3142
    for lat in (-60.0, 12.5, 45.0, 51.48, 78.0):
        c2, s2 = np.cos(np.radians(lat)) ** 2, np.sin(np.radians(lat)) ** 2
        want = (a * GAMMA_E * c2 + b * GAMMA_P * s2) / np.sqrt(a * a * c2 + b * b * s2)
        # the two forms agree to the rounding of the published constants (~1e-9 m/s^2)
        assert normal_gravity(lat) == pytest.approx(want, abs=2e-9)
    assert normal_gravity(45.0, 1000.0) == pytest.approx(normal_gravity(45.0) - 3.086e-3,
                                                         abs=1e-15)


@pytest.mark.parametrize(("args", "parameter"),
                         [((91.0,), "latitude_deg"), ((-90.5,), "latitude_deg"),
                          ((float("nan"),), "latitude_deg"), (("north",), "latitude_deg"),
                          ((45.0, 20001.0), "height_m"), ((45.0, -1001.0), "height_m"),
                          ((45.0, float("inf")), "height_m")])
def test_normal_gravity_ranges(args, parameter):
    with pytest.raises(AccelcalError) as exc:
        normal_gravity(*args)
    assert exc.value.parameter == parameter


@pytest.mark.parametrize("name", ["accelcal.physics.gravity",
                                  "accelcal.methods.triad.identify"])
def test_doctests(name):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted
    assert result.failed == 0
