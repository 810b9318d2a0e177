"""The acceptance tests' measurement models: closed forms against Kragten re-runs, the CLI."""

import json
import math

import numpy as np
import pytest

from accelcal.budget import budgets, model_inputs
from accelcal.budget.lab import load_lab
from accelcal.methods import acceptance
from accelcal.methods.acceptance.budget import INPUTS, rerun
from helpers.budget import lab_text, standard
from helpers.cli import run_cli

ARCSEC = math.pi / 648000.0


def _by(bs, coefficient):
    return next(b for b in bs if b.coefficient == coefficient)


def _row(budget, quantity):
    return next(r for r in budget.rows if r.quantity == quantity)


def _lab(tmp_path, *standards):
    path = tmp_path / "lab.toml"
    path.write_text(lab_text(*standards), encoding="utf-8")
    return load_lab(path)


def _kragten(run, name, **shift):
    """``(y(+x) - y(-x)) / 2`` of row ``name`` for the perturbation ``shift`` (one keyword)."""
    (key, step), = shift.items()
    minus = -np.asarray(step) if np.ndim(step) else -step
    return (run(**{key: step}).value(name) - run(**{key: minus}).value(name)) / 2.0


def _per_element(run, name, key, n, step):
    """Root-sum-square over ``n`` elements of a vector perturbation, per unit of ``step``."""
    total = 0.0
    for i in range(n):
        shift = np.zeros(n)
        shift[i] = step
        total += (_kragten(run, name, **{key: shift}) / step) ** 2
    return math.sqrt(total)


@pytest.fixture(scope="module")
def threshold():
    rec = acceptance.simulate("threshold", scale_factor=1.25, output_unit="V", noise=6e-6,
                              increments=(0.5, 2.0, 4.0, 8.0), reversals=2, breakaway=5e-6,
                              seed=2)
    return rec, acceptance.reduce(rec)


def test_threshold_closed_forms_match_the_reduction_run_again(threshold, tmp_path):
    rec, red = threshold
    lab = _lab(tmp_path, standard("local_gravity", 9.81, "m/s^2", U=0.05, k=2,
                                  uncertainty_unit="mGal"),
               standard("head_angle", 0.0, "arcsec", bounds=0.5, distribution="rectangular"),
               standard("daq_gain", 0.0, "ppm", u=10.0),
               standard("daq_linearity", 0.0, "ppm", u=20.0),
               standard("daq_resolution", 0.0, "uV", bounds=0.6, distribution="rectangular"))
    bs = budgets(red, lab, records=rec)
    run = rerun(rec, red)
    decided = _by(bs, "threshold")
    # local gravity: the increment is g / g_n of its told value, u(g)/g of the result
    assert _row(decided, "local_gravity").contribution == pytest.approx(
        decided.estimate * 0.025e-5 / 9.81, rel=1e-9)
    assert _kragten(run, "threshold", input_scale=1e-6) / 1e-6 * 1e6 == pytest.approx(
        decided.estimate, rel=1e-6)
    # the head: two positions at null, each off by e: sqrt(2) * 4.848 ug per arcsec
    angle = _row(decided, "head_angle")
    assert angle.sensitivity == pytest.approx(math.sqrt(2) * ARCSEC * 1e6, rel=1e-6)
    n = np.unique(rec.input).size
    step = 0.01 * ARCSEC
    assert _per_element(run, "threshold", "angles", n, step) * 1e6 * ARCSEC == pytest.approx(
        angle.sensitivity, rel=1e-3)
    for k in (2, 4):
        name = f"response_{k}"
        b = _by(bs, name)
        assert _per_element(run, name, "angles", n, step) * ARCSEC == pytest.approx(
            abs(_row(b, "head_angle").sensitivity), rel=1e-3)  # 3e-5: second order
        assert _kragten(run, name, gain=1e-6) / 1e-6 * 1e-6 == pytest.approx(
            _row(b, "daq_gain").sensitivity, rel=1e-4)
        assert _kragten(run, name, linearity=1e-4) / 1e-4 * 1e-6 == pytest.approx(
            _row(b, "daq_linearity").sensitivity, rel=1e-6)
        dwells = len(red.observations["dwell_input"])
        assert _per_element(run, name, "dwell_offsets", dwells, 1e-7) * 1e-6 == pytest.approx(
            _row(b, "daq_resolution").sensitivity, rel=1e-4)
    assert _row(decided, "daq_gain").sensitivity == 0.0
    assert _row(_by(bs, "error_probability"), "head_angle").sensitivity == 0.0


def test_hysteresis_head_repeatability_and_daq(tmp_path):
    rec = acceptance.simulate("hysteresis", scale_factor=1.25, output_unit="V", noise=6e-6,
                              cycle_step=30.0, dwell=2.0, hysteresis=20e-6, seed=4)
    red = acceptance.reduce(rec)
    lab = _lab(tmp_path, standard("head_repeatability", 0.0, "arcsec", u=0.2),
               standard("daq_gain", 0.0, "ppm", u=10.0),
               standard("daq_linearity", 0.0, "ppm", u=20.0),
               standard("daq_resolution", 0.0, "uV", u=0.3))
    bs = budgets(red, lab, records=rec)
    run = rerun(rec, red)
    dwells = len(red.observations["dwell_input"])
    points = red.provenance["points_g"]
    for k in (0, len(points) // 2):
        name = f"hysteresis_{k + 1}"
        b = _by(bs, name)
        # one visit on each leg: cos(theta) sqrt(2) per rad of each visit's error
        rep = _row(b, "head_repeatability")
        cos = math.sqrt(1.0 - points[k] ** 2)
        assert rep.sensitivity == pytest.approx(cos * math.sqrt(2) * ARCSEC * 1e6, rel=1e-9)
        assert (_per_element(run, name, "visits", dwells, 1e-3 * ARCSEC) * ARCSEC * 1e6
                == pytest.approx(rep.sensitivity, rel=1e-6))
        assert (_per_element(run, name, "dwell_offsets", dwells, 1e-7) * 1e6 * 1e-6
                == pytest.approx(_row(b, "daq_resolution").sensitivity, rel=1e-6))
        assert _kragten(run, name, gain=1e-6) / 1e-6 * 1e6 * 1e-6 == pytest.approx(
            _row(b, "daq_gain").sensitivity, rel=1e-4)
        assert _kragten(run, name, linearity=1e-4) / 1e-4 == pytest.approx(
            _row(b, "daq_linearity").sensitivity, rel=1e-6, abs=1e-9)
    assert "local_gravity" not in INPUTS["hysteresis"]


@pytest.fixture(scope="module")
def centrifuge_range():
    rec = acceptance.simulate("range", seed=5)
    return rec, acceptance.reduce(rec)


def test_range_on_a_centrifuge_radius_rate_and_daq(centrifuge_range, tmp_path):
    rec, red = centrifuge_range
    lab = _lab(tmp_path, standard("centrifuge_radius", 0.5, "m", u=20.0, uncertainty_unit="um"),
               standard("centrifuge_rate", 0.0, "ppm", u=5.0),
               standard("local_gravity", 9.81, "m/s^2", u=1e-5),
               standard("daq_gain", 0.0, "ppm", u=10.0),
               standard("daq_offset", 0.0, "uV", u=2.0))
    assert "local_gravity" not in model_inputs(red)  # inputs Omega^2 R / g_n
    bs = budgets(red, lab, records=rec)
    run = rerun(rec, red)
    pos = _by(bs, "range_pos")
    # u(R)/R and 2 u(Omega)/Omega of the range, in closed form ...
    assert _row(pos, "centrifuge_radius").contribution == pytest.approx(
        pos.estimate * 20e-6 / 0.5, rel=1e-9)
    assert _row(pos, "centrifuge_rate").contribution == pytest.approx(
        2 * pos.estimate * 5e-6, rel=1e-9)
    # ... and by the reduction of every input scaled by (1 +- e)
    assert _kragten(run, "range_pos", input_scale=1e-6) / 1e-6 == pytest.approx(
        pos.estimate, rel=1e-3)
    assert abs(_kragten(run, "range_pos", gain=1e-5)) < 1e-6 * pos.estimate  # the line absorbs it
    assert _row(pos, "daq_gain").sensitivity == 0.0
    before = _by(bs, "bias_before")
    k1 = rec.scale_factor
    assert _row(before, "daq_offset").sensitivity == pytest.approx(1e6 * 1e-6 / k1, rel=1e-12)
    assert _kragten(run, "bias_before", offset=1e-6) / 1e-6 * 1e6 * 1e-6 == pytest.approx(
        _row(before, "daq_offset").sensitivity, rel=1e-6)
    assert _row(_by(bs, "overload_shift"), "daq_offset").sensitivity == 0.0
    assert all(r.contribution == 0.0 for r in _by(bs, "clipped_samples").rows)


def test_range_in_the_gravity_field_takes_u_g_over_g(tmp_path):
    from accelcal.rigs.acceptance_runs import simulate_range

    rec = simulate_range(inputs=tuple(0.1 * k for k in range(1, 11)), full_scale=0.8,
                         rail=None, k2=0.0, overload_shift=0.0, seed=1)
    red = acceptance.reduce(rec)
    assert model_inputs(red) == INPUTS["range in the gravity field"]
    lab = _lab(tmp_path, standard("local_gravity", 9.812617, "m/s^2", U=0.05, k=2,
                                  uncertainty_unit="mGal"),
               standard("centrifuge_radius", 0.5, "m", u=1e-5))
    b = _by(budgets(red, lab, records=rec), "range_pos")
    assert _row(b, "local_gravity").contribution == pytest.approx(
        b.estimate * 0.025e-5 / 9.812617, rel=1e-9)
    assert "centrifuge_radius" not in [r.quantity for r in b.rows]


def test_turn_on_gravity_and_offset(tmp_path):
    import dataclasses

    sim = acceptance.simulate("turn-on", turn_ons=4, pairs=2, dwell=3.0, seed=6)
    rec = dataclasses.replace(sim, output=sim.output * 1.25, output_unit="V", scale_factor=1.25)
    red = acceptance.reduce(rec)
    lab = _lab(tmp_path, standard("local_gravity", 9.81, "m/s^2", u=1e-4),
               standard("daq_offset", 0.0, "uV", u=2.0))
    bs = budgets(red, lab, records=rec)
    run = rerun(rec, red)
    for name in ("bias_1", "bias_mean", "bias_repeatability"):
        b = _by(bs, name)
        assert _row(b, "local_gravity").contribution == pytest.approx(
            abs(b.estimate) * 1e-4 / 9.81, rel=1e-9)
        assert _kragten(run, name, input_scale=1e-6) / 1e-6 * 1e6 == pytest.approx(
            b.estimate, rel=1e-4)
        assert _kragten(run, name, offset=1e-6) / 1e-6 == pytest.approx(
            _row(b, "daq_offset").sensitivity, rel=1e-6, abs=1e-9)
    assert _row(_by(bs, "bias_1"), "daq_offset").sensitivity == pytest.approx(1 / 1.25, rel=1e-3)
    assert _row(_by(bs, "scale_repeatability"), "local_gravity").sensitivity == 0.0
    # the sensor's temperature through the bias temperature coefficient of the model given
    from accelcal.model import ErrorModel, TemperatureTerms

    model = ErrorModel(K1=1.25, temperature=TemperatureTerms(20.0, {"K0_T1": 2e-6}))
    hot = _lab(tmp_path, standard("sensor_temperature", 23.0, "degC", u=0.1))
    warm = budgets(red, hot, records=rec, model=model)
    assert _row(_by(warm, "bias_mean"), "sensor_temperature").sensitivity == pytest.approx(2.0)
    assert _row(_by(warm, "drift"), "sensor_temperature").sensitivity == 0.0


def test_magnetic_coil_constant(tmp_path):
    rec = acceptance.simulate("magnetic", dwell=2.0, seed=7)
    red = acceptance.reduce(rec)
    lab = _lab(tmp_path, standard("coil_constant", 0.3715, "mT/A", U=0.2, k=2,
                                  uncertainty_unit="%"),
               standard("daq_gain", 0.0, "ppm", u=10.0))
    bs = budgets(red, lab, records=rec)
    run = rerun(rec, red)
    for name in ("m_x", "m_y", "m_z"):
        b = _by(bs, name)
        coil = _row(b, "coil_constant")
        assert coil.unit == "mT/A"
        assert coil.contribution == pytest.approx(abs(b.estimate) * 0.001, rel=1e-9)
        assert _kragten(run, name, field_scale=1e-6) / 1e-6 == pytest.approx(
            coil.sensitivity * 0.3715, rel=1e-6)
        assert _kragten(run, name, gain=1e-6) / 1e-6 * 1e-6 == pytest.approx(
            _row(b, "daq_gain").sensitivity, rel=1e-6)


def test_cli_lists_the_tests_missing_inputs_and_writes_the_budget_keys(tmp_path, capsys):
    from accelcal.io.formats import acceptance as steps_format

    path = tmp_path / "mag.csv"
    steps_format.write(path, acceptance.simulate("magnetic", dwell=2.0, seed=8))
    lab = tmp_path / "lab.toml"
    lab.write_text(lab_text(standard("daq_gain", 0.0, "ppm", u=10.0),
                            standard("local_gravity", 9.81, "m/s^2", u=1e-4)), encoding="utf-8")
    code, out, err = run_cli(["budget", path, "--lab", lab, "--format", "json"], capsys)
    assert code == 0, err
    assert "coil_constant" in err
    assert "acceptance/magnetic model" in err
    for other in ("centrifuge_radius", "head_angle", "daq_resolution"):  # not this test's
        assert other not in err
    found = json.loads(out)
    assert [b["coefficient"] for b in found] == ["m_x", "m_y", "m_z"]
    for b in found:
        assert {"coefficient", "estimate", "unit", "u_c", "nu_eff", "k", "U", "correlated",
                "rows"} <= set(b)
        assert any("coil_constant" in n for n in b["notes"])
        assert [r["quantity"] for r in b["rows"]] == ["Type A", "daq_gain"]
        for r in b["rows"]:
            assert {"quantity", "estimate", "u", "unit", "distribution", "sensitivity",
                    "contribution", "dof", "share"} <= set(r)


def test_the_descriptor_declares_every_tests_inputs():
    from accelcal.catalog import method

    declared = method("acceptance").budget_inputs
    assert set(declared) == {q for test in INPUTS.values() for q in test}


def test_a_record_without_its_data_keeps_the_closed_forms_of_its_results(threshold, tmp_path,
                                                                          capsys):
    import dataclasses

    from accelcal.calibration import lab_info
    from accelcal.io.formats import acceptance as steps_format

    rec, _ = threshold
    data = tmp_path / "steps.csv"
    meta = {"serial": "SN-7", "operator": "op", "date": "2026-11-20T10:00:00+00:00"}
    steps_format.write(data, dataclasses.replace(rec, metadata={**rec.metadata, **meta}))
    red = acceptance.reduce(data)
    (record,) = red.to_records(lab_info([data]), input_files=[data])
    record.save(tmp_path / "threshold.json")
    data.unlink()  # the step record is gone: the budget of the record's own numbers
    lab = tmp_path / "lab.toml"
    lab.write_text(lab_text(standard("local_gravity", 9.81, "m/s^2", u=1e-4),
                            standard("head_angle", 0.0, "arcsec", u=0.5)), encoding="utf-8")
    code, out, err = run_cli(["budget", tmp_path / "threshold.json", "--lab", lab,
                              "--coefficient", "threshold", "--format", "json"], capsys)
    assert code == 0, err
    (b,) = json.loads(out)
    rows = {r["quantity"]: r for r in b["rows"]}
    assert rows["local_gravity"]["contribution"] == pytest.approx(
        b["estimate"] * 1e-4 / 9.81, rel=1e-9)
    assert "head_angle" not in rows
    assert any(n.startswith("head_angle: the input data were not found") for n in b["notes"])


def _expire(text: str, quantity: str) -> str:
    """The lab file ``text`` with ``quantity``'s standard due in 2020."""
    import re

    at = text.index(f'quantity = "{quantity}"')
    due = re.compile(r"due = \d{4}").search(text, at)
    return text[:due.start()] + "due = 2020" + text[due.end():]


def test_a_certificate_checks_the_due_dates_of_its_tests_own_inputs(threshold, tmp_path):
    # coil_constant is an input of the family's magnetic test, head_angle of the threshold's
    import dataclasses

    from accelcal.calibration import lab_info
    from accelcal.certificate.content import build
    from accelcal.errors import AccelcalError
    from accelcal.io.formats import acceptance as steps_format
    from helpers.certificates import LAB

    rec, _ = threshold
    data = tmp_path / "steps.csv"
    meta = {"serial": "SN-7", "operator": "op", "date": "2026-11-20T10:00:00+00:00"}
    steps_format.write(data, dataclasses.replace(rec, metadata={**rec.metadata, **meta}))
    (record,) = acceptance.reduce(data).to_records(lab_info([data]), input_files=[data])
    text = LAB.read_text(encoding="utf-8")
    coil = tmp_path / "coil.toml"
    coil.write_text(_expire(text, "coil_constant"), encoding="utf-8")
    doc = build([record], load_lab(coil), issued="2026-11-26")
    assert doc["expired_standards"] == []
    head = tmp_path / "head.toml"
    head.write_text(_expire(text, "head_angle"), encoding="utf-8")
    with pytest.raises(AccelcalError, match="head_angle"):
        build([record], load_lab(head), issued="2026-11-26")
