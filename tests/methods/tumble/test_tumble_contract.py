"""The tumble reduction under the reduction contract, the tumble rig and the record format.

The contract (tests/helpers/contract.py) runs random models through the rig
(:mod:`accelcal.rigs.tumble`) and :func:`accelcal.methods.tumble.reduce_tumble`
by both routes; the rig is checked against the error model directly; the
format (:mod:`accelcal.io.formats.tumble`) by round trips and by a file
written in the layout of earlier accelcal versions.
"""

import json
import subprocess
import sys

import numpy as np
import pytest

import accelcal
from accelcal import ErrorModel
from accelcal.errors import AccelcalError
from accelcal.io.formats import tumble as tumble_format
from accelcal.io.records import write_record
from accelcal.methods.tumble import DEFAULT_TERMS, reduce_tumble
from accelcal.rigs.tumble import simulate, uniform_positions
from helpers.contract import ReductionContract, spread_terms, true_value

REL, ABS = 1e-12, 1e-13
"""As in test_tumble.py: rounding of ~K1 outputs through sums of <= 24 terms with
factors <= 8 leaves a few 1e-15 g/g^n; ABS is ~50x that, REL bounds K1."""


def random_model(rng, axis, output_unit="V", *, every_term=False):
    """Random default terms; with ``every_term`` also the cross-axis nonlinearity and the
    asymmetry, at the default accelerometer's magnitudes with random signs."""
    small = [t for t in DEFAULT_TERMS[axis] if t != "K1"]
    k1 = rng.uniform(0.5, 3.0) * rng.choice([-1.0, 1.0])
    extra = spread_terms(accelcal.default_model(), rng, (CROSS[axis], "K0_asym", "K1_asym")) \
        if every_term else {}
    return ErrorModel(K1=k1, output_unit=output_unit,
                      **{t: rng.uniform(-2e-3, 2e-3) for t in small}, **extra)


CROSS = {"OA": "Kpp", "PA": "Koo"}
"""The cross-axis nonlinearity a rotation about each axis cannot separate from K0 and K2."""




class _TumbleContract(ReductionContract):
    AXIS = "OA"
    ROUTE = "fourier"
    REPEATS = 1
    NOISE = 2e-5  # output unit per reading

    def positions(self, rng):
        return uniform_positions(24, rng.uniform(-np.pi, np.pi))

    TYPE_B = True  # the Fourier route bounds K0', K1' by their priors

    def truth(self, rng):
        return random_model(rng, self.AXIS, every_term=True)

    def simulate(self, truth, rng, noisy):
        return simulate(self.positions(rng), truth, rotation_axis=self.AXIS,
                        noise=self.NOISE if noisy else 0.0, repeats=self.REPEATS, seed=rng)

    def reduce(self, data):
        outputs = data.outputs if data.repeats > 1 else data.outputs[:, 0]
        return reduce_tumble(data.angles_rad, outputs, rotation_axis=data.rotation_axis,
                             output_unit=data.output_unit, route=self.ROUTE,
                             repeats=data.repeats > 1)

    def expected(self, truth):
        # by plain name; row_truth gives the truth of each row's name (K0+Kpp, ...)
        names = [*DEFAULT_TERMS[self.AXIS], *(("K0_asym", "K1_asym") if self.ROUTE == "lsq"
                                              else ())]
        return [{n: getattr(truth, n) for n in names}]

    def row_truth(self, truth, row, value):
        return true_value(truth if isinstance(truth, ErrorModel) else accelcal.default_model(),
                          row)

    def default_case(self):
        model = accelcal.default_model()
        data = simulate(uniform_positions(24), model, rotation_axis=self.AXIS, noise=0.0,
                        repeats=self.REPEATS)
        return data, self.expected(model)

    def noise_free_tolerance(self, name, value):
        # Rounding of the outputs (ABS, REL above) amplified by the conditioning of the
        # equilibrated design (about 15 for uniform N >= 9, below 100 for the
        # non-uniform set used here).
        return REL * abs(value) + 100 * ABS


class TestContractFourierOA(_TumbleContract):
    pass


class TestContractLeastSquaresPA(_TumbleContract):
    AXIS = "PA"
    ROUTE = "lsq"
    REPEATS = 3
    TYPE_B = False  # K0' and K1' estimated: nothing is bounded by a prior

    def positions(self, rng):
        # 20 positions, non-uniform: jittered by up to 3 deg
        return uniform_positions(20) + np.radians(rng.uniform(-3, 3, 20))


def test_contract_reductions_carry_their_fields():
    rng = np.random.default_rng(3)
    t = TestContractLeastSquaresPA()
    truth = t.truth(rng)
    red = t.reduce(t.simulate(truth, rng, noisy=True))
    assert (red.family, red.method) == ("tumble", "tumble/lsq")
    assert red.assumed("rotation_axis") == "PA"
    assert red.assumed("noise") == "residuals"
    assert red.assumed("repeats") == 3
    assert red.dof == red.estimate.dof == 20 - 9  # the seven default terms, K0' and K1'
    assert red.identifiability.full_rank
    assert red.estimate["K1"] == red.models[0].K1
    assert red.scale_factor() == red.estimate["K1"]
    assert set(red.observations) >= {"angles", "outputs", "fitted"}
    stems = [f[0] for f in red.figures()]
    assert stems == ["tumble-residuals"]  # non-uniform: no harmonics figure
    known = reduce_tumble(uniform_positions(12), np.cos(uniform_positions(12)), sigma=1e-6)
    assert known.dof == 0
    assert known.assumed("noise") == "given"
    assert [f[0] for f in known.figures()] == ["tumble-residuals", "tumble-harmonics"]


# ------------------------------------------------------------------------ rig
@pytest.mark.parametrize("axis", ["OA", "PA"])
def test_rig_noise_free_outputs_are_the_models(axis):
    m = random_model(np.random.default_rng(1), axis, "mV")
    theta = uniform_positions(12, 0.3)
    rec = simulate(theta, m, rotation_axis=axis, noise=0.0, repeats=2)
    c, s = np.cos(theta), np.sin(theta)
    a = (c, 0.0, s) if axis == "OA" else (s, c, 0.0)
    np.testing.assert_allclose(rec.outputs, np.repeat(m.output(*a)[:, None], 2, axis=1),
                               rtol=0, atol=1e-15 * abs(m.K1))
    assert rec.outputs.shape == (12, 2)
    assert (rec.rotation_axis, rec.output_unit) == (axis, "mV")
    assert rec.metadata["noise_sd"] == 0.0
    assert rec.metadata["true_model"]["K1"] == m.K1
    np.testing.assert_array_equal(rec.angles_rad, theta)


def test_rig_noise_seed_and_position_error():
    m = ErrorModel(K1=1.2, K0=1e-4)
    theta = uniform_positions(8)
    a = simulate(theta, m, noise=1e-3, repeats=4000, seed=5)
    b = simulate(theta, m, noise=1e-3, repeats=4000, seed=5)
    np.testing.assert_array_equal(a.outputs, b.outputs)
    assert a.metadata["seed"] == 5
    assert a.metadata["true_model"]["sigma"] == pytest.approx(1e-3 / 1.2)
    # 32000 readings: the SD of the sample SD is 0.4 %
    resid = a.outputs - a.outputs.mean(axis=1, keepdims=True)
    assert resid.std() == pytest.approx(1e-3, rel=0.02)
    # Same as the command line always drew: model noise over the repeated positions
    rng = np.random.default_rng(5)
    want = m.replace(sigma=1e-3 / 1.2).output(np.cos(np.repeat(theta, 4000)), 0.0,
                                              np.sin(np.repeat(theta, 4000)), rng=rng)
    np.testing.assert_allclose(a.outputs.reshape(-1), want, rtol=0, atol=1e-15)
    # A position error moves the true angle; the record keeps the nominal one.
    p = simulate(theta, m, noise=0.0, position_sd=1e-3, seed=1)
    np.testing.assert_array_equal(p.angles_rad, theta)
    assert p.metadata["position_sd_rad"] == 1e-3
    shift = p.outputs[:, 0] - simulate(theta, m, noise=0.0).outputs[:, 0]
    assert 0 < np.abs(shift).max() < 1.2 * 5e-3


@pytest.mark.parametrize(
    ("kwargs", "parameter"),
    [
        ({"repeats": 0}, "repeats"),
        ({"noise": -1.0}, "noise"),
        ({"noise": float("nan")}, "noise"),
        ({"position_sd": -1.0}, "position_sd"),
        ({"rotation_axis": "IA"}, "rotation_axis"),
        ({"positions_rad": [[0.0, 1.0]]}, "positions_rad"),
        ({"positions_rad": []}, "positions_rad"),
    ],
)
def test_rig_bad_input(kwargs, parameter):
    args = {"positions_rad": uniform_positions(8), **kwargs}
    with pytest.raises(AccelcalError) as exc:
        simulate(args.pop("positions_rad"), ErrorModel(K1=1.0), **args)
    assert exc.value.parameter == parameter


# --------------------------------------------------------------------- format
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_format_round_trip(tmp_path, suffix):
    m = ErrorModel(K1=1.2, K0=1e-4, Kp=2e-4, output_unit="mA")
    rec = simulate(uniform_positions(12, 0.1), m, rotation_axis="OA", noise=1e-5, repeats=3,
                   seed=2)
    rec = type(rec)(rec.angles_rad, rec.outputs, rec.rotation_axis, rec.output_unit,
                    {**rec.metadata, "serial": "SN-7", "operator": "op"})
    path = tmp_path / f"t{suffix}"
    tumble_format.write(path, rec)
    back = tumble_format.read(path)
    np.testing.assert_allclose(back.angles_rad, rec.angles_rad, rtol=1e-15, atol=1e-15)
    np.testing.assert_array_equal(back.outputs, rec.outputs)
    assert (back.rotation_axis, back.output_unit) == ("OA", "mA")
    assert back.metadata == rec.metadata
    assert back.lab.serial() == "SN-7"
    assert back.repeats == 3


def test_format_reads_the_files_earlier_versions_wrote(tmp_path):
    """The layout `accelcal tumble simulate` has always written: one row per reading,
    angle in degrees, the readings of a position together, rotation_axis and
    output_unit in the metadata (and noise_sd, seed, true_model)."""
    path = tmp_path / "old.csv"
    deg = np.repeat(10.0 + 360.0 * np.arange(8) / 8, 2)
    out = np.cos(np.radians(deg)) + 1e-6 * np.arange(16)
    meta = {"units": {"angle": "deg", "output": "V"}, "rotation_axis": "PA",
            "output_unit": "V", "noise_sd": 1e-6, "seed": 0, "true_model": {"K1": 1.0}}
    write_record(path, "tumble", meta, {"angle": deg, "output": out})
    lines = path.read_text().splitlines()
    assert lines[0] == "# accelcal record"
    assert lines[2] == "angle,output"
    rec = tumble_format.read(path)
    np.testing.assert_array_equal(rec.angles_rad, np.radians(deg[::2]))
    np.testing.assert_array_equal(rec.outputs, out.reshape(8, 2))
    assert rec.metadata == {"noise_sd": 1e-6, "seed": 0, "true_model": {"K1": 1.0}}
    # rows in any order: positions sorted by angle, readings in file order
    shuffled = tmp_path / "shuffled.csv"
    order = np.array([3, 0, 5, 1, 2, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14])
    write_record(shuffled, "tumble", meta, {"angle": deg[order], "output": out[order]})
    rec2 = tumble_format.read(shuffled)
    np.testing.assert_array_equal(rec2.angles_rad, rec.angles_rad)
    np.testing.assert_array_equal(rec2.outputs[0], out[[0, 1]])
    # and the file a written record makes is the same layout
    again = tmp_path / "again.csv"
    tumble_format.write(again, rec)
    assert again.read_text().splitlines()[2] == "angle,output"
    assert json.loads(again.read_text().splitlines()[1][2:])["rotation_axis"] == "PA"


@pytest.mark.parametrize(
    ("meta", "match"),
    [
        ({"rotation_axis": "OA"}, "metadata lacks output_unit"),
        ({"rotation_axis": "XA", "output_unit": "V"}, "rotation_axis 'XA' is not one of OA, PA"),
        ({"rotation_axis": "OA", "output_unit": "furlong"}, "output_unit 'furlong'"),
        ({"rotation_axis": "OA", "output_unit": "V", "serial": ""}, "metadata 'serial'"),
    ],
)
def test_format_bad_metadata(tmp_path, meta, match):
    path = tmp_path / "bad.csv"
    write_record(path, "tumble", {"units": {"angle": "deg", "output": "V"}, **meta},
                 {"angle": [0.0, 90.0], "output": [1.0, 0.0]})
    with pytest.raises(AccelcalError, match=match):
        tumble_format.read(path)


def test_format_refuses_unequal_repeats(tmp_path):
    path = tmp_path / "r.csv"
    meta = {"units": {"angle": "deg", "output": "V"}, "rotation_axis": "OA", "output_unit": "V"}
    write_record(path, "tumble", meta, {"angle": [0.0, 0.0, 90.0], "output": [1.0, 1.0, 0.0]})
    with pytest.raises(AccelcalError, match="different numbers of repeated readings"):
        tumble_format.read(path)


def test_format_imports_no_method_rig_or_cli():
    code = ("import sys, accelcal.io.formats.tumble; "
            "bad = [m for m in sys.modules if m.startswith(('accelcal.methods', 'accelcal.rigs', "
            "'accelcal.cli'))]; print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
