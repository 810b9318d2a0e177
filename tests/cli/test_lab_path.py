"""The lab's path in the library: one Python call per method gives the rows the CLI prints."""

import json

import numpy as np
import pytest

from accelcal.cli import main


def _cli_json(args, capsys):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert info.value.code == 0, err
    return json.loads(out)


def _same_rows(python_rows, cli_rows):
    """The same columns and values (floats to rounding: the CLI's JSON round-trips them)."""
    assert len(python_rows) == len(cli_rows)
    for mine, theirs in zip(python_rows, cli_rows, strict=True):
        assert set(mine) == set(theirs)
        for key, value in mine.items():
            if isinstance(value, float) and np.isnan(value):
                assert theirs[key] is None or np.isnan(theirs[key])
            elif isinstance(value, float):
                assert theirs[key] == pytest.approx(value, rel=1e-12, abs=1e-300), key
            else:
                assert theirs[key] == value, key


@pytest.fixture(scope="module")
def triad_record(tmp_path_factory):
    from accelcal.io.formats import triad as triad_format
    from accelcal.methods.triad.model import TriadCalibration
    from accelcal.rigs.triad import simulate

    truth = TriadCalibration([0.05, -0.08, 0.12], [1.01, 0.995, 1.02], [1e-3, -2e-3, 1.5e-3])
    path = tmp_path_factory.mktemp("triad") / "triad.csv"
    triad_format.write(path, simulate(truth, 12, still=10.0, noise_sd=0.005, seed=4))
    return path


@pytest.mark.parametrize("args", [
    {},  # known orientations from the record's positions
    {"orientations": "unknown", "init_static": 8.0},  # factor chosen by the residual
    {"orientations": "unknown", "init_static": 8.0, "factor": 3.0, "latitude": 45.0,
     "height": 120.0},
])
def test_triad_run_gives_the_rows_of_triad_calibrate(triad_record, tmp_path, capsys, args):
    from accelcal.methods import triad

    lab = triad.run(triad_record, **args)
    flags = []
    for name, value in args.items():
        flags += [f"--{name.replace('_', '-')}", value]
    doc = _cli_json(["triad", "calibrate", triad_record, "--out", tmp_path / "cal.json",
                     "--format", "json", *flags], capsys)
    expected = "triad/known-orientations" if not args else "triad/gravity-norm"
    assert lab.reduction.method == doc["method"] == expected
    _same_rows(lab.reduction.rows(), doc["coefficients"])
    _same_rows(lab.norm_rows(), doc["norm_residuals"])
    assert doc["gravity"] == pytest.approx(lab.summary()["gravity"], rel=1e-15)
    assert doc["positions"] == 12
    assert (doc["factor_sweep"] != []) == (args.get("orientations") == "unknown"
                                          and "factor" not in args)
    if "latitude" in args:  # WGS84 normal gravity at 45 deg, 120 m, not the record's 9.80665
        assert doc["gravity"] == pytest.approx(9.80583, abs=1e-4)


def test_triad_run_takes_a_recording_already_read(triad_record):
    from accelcal.io.recordings import read_recording
    from accelcal.methods import triad

    rec = read_recording(triad_record, channels=3)
    by_path, by_record = triad.run(triad_record), triad.run(rec)
    np.testing.assert_allclose(by_record.reduction.estimate.values,
                               by_path.reduction.estimate.values, rtol=1e-12)


@pytest.mark.parametrize(("kwargs", "parameter"), [
    ({"orientations": "sideways"}, "orientations"),
    ({"gravity": 9.8, "latitude": 45.0}, "gravity"),
    ({"height": 10.0}, "height"),
    ({"positions": "up.json", "orientations": "unknown"}, "positions"),
])
def test_triad_run_names_the_parameter_at_fault(triad_record, kwargs, parameter):
    from accelcal import AccelcalError
    from accelcal.methods import triad

    with pytest.raises(AccelcalError) as info:
        triad.run(triad_record, **kwargs)
    assert info.value.parameter == parameter


def _simulate(args):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    assert info.value.code == 0


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One small simulated file (or directory) of every method, by ``accelcal ... simulate``."""
    d = tmp_path_factory.mktemp("lab")
    for args in (
        ["tumble", "simulate", "--out", d / "tumble.csv", "--seed", "5"],
        ["thermal", "simulate", "--out", d / "thermal.csv", "--seed", "4", "--setpoints",
         "-30,0,30,60,15,-15", "--points", "12", "--dwell", "30", "--warmup", "1800"],
        ["centrifuge", "simulate", "--out", d / "centrifuge.csv", "--radius-error", "2e-4",
         "--radius-sd", "1e-4", "--readings", "2", "--spinup", "1", "--seed", "4"],
        ["noise", "simulate", "--N", "2e-5", "--B", "3e-6", "--rate", "50", "--duration",
         "200", "--seed", "4", "--out", d / "still.csv"],
        ["vre", "simulate", "--out", d / "vre1.csv", "--overload", "1,2", "--amplitude", "5",
         "--duration", "0.2", "--seed", "2"],
        ["vre", "simulate", "--out", d / "vre4.csv", "--overload", "4,-4", "--amplitude", "5",
         "--duration", "0.2", "--seed", "3"],
        ["dividing-head", "simulate", "--positions", "24", "--mounts", "0,90,180,270",
         "--angle-error", "harmonics:2c=5arcsec,3s=1arcsec", "--first-harmonic",
         "1.5e-5,-1.9e-6", "--noise", "1e-6", "--seed", "1", "--out", d / "head.csv"],
        ["transverse", "simulate", "--amplitude", "5", "--angles", "0:330:30", "--gravity",
         "1", "--rest", "--noise", "1e-6", "--seed", "3", "--out", d / "shaker"],
    ):
        _simulate(args)
    return d


@pytest.mark.parametrize("route", ["auto", "lsq"])
def test_tumble_reduce_gives_the_rows_of_the_cli(files, capsys, route):
    from accelcal.io.formats import tumble as tumble_format
    from accelcal.methods import tumble

    path = files / "tumble.csv"
    red = tumble.reduce(path, route=route)
    _same_rows(red.rows(), _cli_json(["tumble", "reduce", path, "--route", route,
                                      "--format", "json"], capsys))
    assert red.method == ("tumble/fourier" if route == "auto" else "tumble/lsq")
    again = tumble.reduce(tumble_format.read(path), route=route)  # a record read before
    np.testing.assert_allclose(again.estimate.values, red.estimate.values, rtol=1e-12)


def test_thermal_reduce_gives_the_rows_of_the_cli(files, capsys):
    from accelcal.methods import thermal

    path = files / "thermal.csv"
    red = thermal.reduce(path, order=1)
    _same_rows(red.rows(), _cli_json(["thermal", "reduce", path, "--order", "1", "--format",
                                      "json"], capsys))
    assert red.method == "thermal/wls"


@pytest.mark.parametrize("joint", [False, True])
def test_centrifuge_reduce_gives_the_rows_of_the_cli(files, capsys, joint):
    from accelcal.methods import centrifuge

    path, one_g = files / "centrifuge.csv", files / "tumble.csv"
    red = centrifuge.reduce(path, one_g=one_g if joint else None)
    rows = _cli_json(["centrifuge", "reduce", path, *(["--with", one_g] if joint else []),
                      "--format", "json"], capsys)
    _same_rows(red.rows(), rows[:len(red.rows())])
    assert red.method == ("centrifuge/joint" if joint else "centrifuge/lsq")
    assert ("radius_error" in red.provenance["estimated"]) == joint


def test_noise_reduce_gives_the_coefficients_of_the_cli(files, capsys):
    from accelcal.io.formats import noise as noise_format
    from accelcal.methods import noise
    from accelcal.methods.noise.fit import coefficients

    path = files / "still.csv"
    red = noise.reduce(path, terms=("N", "B"))
    doc = _cli_json(["noise", "fit", path, "--terms", "N,B", "--format", "json"], capsys)
    mine = json.loads(json.dumps(coefficients(red)))
    assert mine.keys() == doc.keys()
    for term in ("N", "B"):
        assert doc[term] == pytest.approx(mine[term], rel=1e-12)
    assert red.method == "noise/ieee952-fit"
    # the record in memory (fitted whole, not streamed) gives the same coefficients
    whole = noise.reduce(noise_format.read(path), terms=("N", "B"))
    np.testing.assert_allclose(whole.estimate.values, red.estimate.values, rtol=1e-9)


def test_vre_reduce_gives_the_rows_of_the_cli(files, capsys):
    from accelcal.methods import vre

    paths = [files / "vre1.csv", files / "vre4.csv"]
    red = vre.reduce(paths, terms=("K2", "K3", "K0_asym"))
    doc = _cli_json(["vre", "fit", *paths, "--terms", "K2,K3,K0_asym", "--format", "json"],
                    capsys)
    _same_rows(red.rows(), doc["coefficients"])
    assert doc["method"] == red.method == "vre/identify"


@pytest.mark.parametrize(("method", "extra"), [
    ("joint", {}),
    ("four", {"first_harmonic": (0.0, 0.0)}),  # given: replaces the file's measured one
])
def test_dividing_head_reduce_gives_the_rows_of_the_cli(files, capsys, method, extra):
    from accelcal.methods import dividing_head

    path = files / "head.csv"
    red = dividing_head.reduce(path, method, **extra)
    flags = ["--first-harmonic", "0,0"] if extra else []
    rows = _cli_json(["dividing-head", "reduce", path, "--method", method, *flags,
                      "--format", "json"], capsys)
    _same_rows(red.rows(), rows)
    assert red.method == f"dividing-head/{method}"


def test_dividing_head_takes_the_records_first_harmonic_unless_one_is_given(files):
    import dataclasses

    from accelcal.io.formats.dividing_head import read_head_record
    from accelcal.methods import dividing_head

    record = dataclasses.replace(read_head_record(files / "head.csv"),
                                 first_harmonic=np.array([1.5e-5, -1.9e-6]),
                                 first_harmonic_sd=1e-6)
    assert dividing_head.lab_options(record, "four") == {
        "first_harmonic": (1.5e-5, -1.9e-6), "first_harmonic_sd": 1e-6}
    assert dividing_head.lab_options(record, "four", first_harmonic=(0.0, 0.0),
                                     covariance=None) == {"first_harmonic": (0.0, 0.0)}
    assert dividing_head.lab_options(record, "single") == {}
    measured = dividing_head.reduce(record, "four")
    zero = dividing_head.reduce(record, "four", first_harmonic=(0.0, 0.0))
    assert not np.allclose(measured.estimate.values, zero.estimate.values, rtol=1e-9, atol=0)


def test_transverse_reduce_gives_the_rows_of_the_cli(files, capsys):
    from accelcal.methods import transverse

    path = files / "shaker"
    red = transverse.reduce(path, route="both")
    rows = _cli_json(["transverse", "fit", path, "--route", "both", "--format", "json"],
                     capsys)
    _same_rows([{"amplitude_g": 5.0, **r, "method": red.method} for r in red.rows()], rows)
    assert red.method == "transverse/both"


def test_every_method_package_has_the_verbs():
    import importlib

    from accelcal.methods import REGISTRY

    uncertainty = {"dividing-head", "transverse", "triad", "vre"}
    plan = {"centrifuge", "response", "triad", "tumble"}
    for family, name in REGISTRY.items():
        package = importlib.import_module(name)
        assert callable(package.simulate), family
        assert callable(package.reduce), family
        assert hasattr(package, "uncertainty") == (family in uncertainty), family
        assert hasattr(package, "plan") == (family in plan), family
