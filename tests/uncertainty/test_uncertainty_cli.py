"""``--uncertainty formal|mc`` on dividing-head reduce, vre fit and transverse fit."""

import json

import numpy as np
import pytest

from accelcal.cli import main

MC_KEYS = ("mc_std", "ci95_low", "ci95_high")
ENGINEERING_SD = ("engineering", "eng_std")
"""Keys whose standard uncertainty is the Monte Carlo one with --uncertainty mc."""


def _run(args, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    out, err = capsys.readouterr()
    return exc.value.code, out, err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One record set per method, simulated once for the module."""
    tmp = tmp_path_factory.mktemp("mc")
    head, vre, shaker = tmp / "head.csv", tmp / "vre.csv", tmp / "shaker"
    for args in (
        ["dividing-head", "simulate", "--out", str(head), "--angle-error", "uniform:1arcsec",
         "--seed", "2"],
        ["vre", "simulate", "--out", str(vre), "--overload", "1,2,4", "--amplitude", "2.5:9.5:1",
         "--noise", "1e-4", "--duration", "0.2", "--sample-rate", "2000"],
        ["transverse", "simulate", "--out", str(shaker), "--paper", "--amplitude", "5",
         "--noise", "1e-4", "--periods", "8", "--sample-rate", "5120"],
    ):
        with pytest.raises(SystemExit) as exc:
            main(args)
        assert exc.value.code == 0
    return {"head": ["dividing-head", "reduce", str(head)], "vre": ["vre", "fit", str(vre)],
            "shaker": ["transverse", "fit", str(shaker)]}


def _rows(kind, out):
    doc = json.loads(out)
    return doc["coefficients"] if kind == "vre" else doc


TYPE_B = {"head": ["--angle-error-level", "1arcsec"], "vre": ["--amplitude-uncertainty", "1"],
          "shaker": ["--reference-uncertainty", "0.5"]}


@pytest.mark.parametrize("kind", ["head", "vre", "shaker"])
def test_mc_adds_columns_and_keeps_the_formal_ones(files, kind, capsys):
    code, formal_out, _ = _run([*files[kind], "--format", "json"], capsys)
    assert code == 0
    formal = _rows(kind, formal_out)
    assert not any(k in formal[0] for k in MC_KEYS)
    args = [*files[kind], "--format", "json", "--uncertainty", "mc", "--trials", "4000",
            "--seed", "3", *TYPE_B[kind]]
    code, out, _ = _run(args, capsys)
    assert code == 0
    rows = _rows(kind, out)
    assert len(rows) == len(formal)
    engineered = 0
    for r, f in zip(rows, formal, strict=True):
        kept = {k: v for k, v in r.items() if k not in (*MC_KEYS, *ENGINEERING_SD)}
        assert kept == {k: v for k, v in f.items() if k not in ENGINEERING_SD}  # unchanged
        assert r["mc_std"] > 0
        assert r["ci95_low"] < r["estimate"] < r["ci95_high"]
        # the engineering units carry the Monte Carlo SD: the formal one's factor times mc_std
        for e, ef in zip(r.get("engineering") or [], f.get("engineering") or [], strict=True):
            assert e["std"] == pytest.approx(ef["std"] * r["mc_std"] / f["std"], rel=1e-12)
            assert e["std"] != pytest.approx(ef["std"], rel=1e-6)
            engineered += 1
        if r.get("engineering"):
            assert r["eng_std"] == r["engineering"][0]["std"]
    assert engineered > 0
    # same seed, same numbers; another seed, other numbers
    assert _run(args, capsys)[1] == out
    other = _rows(kind, _run([*args[:-len(TYPE_B[kind]) - 1], "4", *TYPE_B[kind]], capsys)[1])
    assert [r["mc_std"] for r in other] != [r["mc_std"] for r in rows]


def test_type_b_input_widens_the_head_interval(files, capsys):
    # the Monte Carlo draws the noise (and the head error given): compared with the formal
    # noise part, without the priors of the terms eq. (5) leaves out
    base = [*files["head"], "--format", "json", "--uncertainty", "mc", "--trials", "4000",
            "--method", "single", "--priors", "none"]
    plain = json.loads(_run(base, capsys)[1])
    wide = json.loads(_run([*base, "--angle-error-level", "3arcsec"], capsys)[1])
    k_f = [i for i, r in enumerate(plain) if r["coefficient"] == "K_F"]
    assert all(wide[i]["mc_std"] > 1.5 * plain[i]["mc_std"] for i in k_f)
    assert np.allclose([r["mc_std"] / r["std"] for r in plain], 1.0, atol=0.1)


@pytest.mark.parametrize("kind", ["head", "vre", "shaker"])
@pytest.mark.parametrize(
    ("extra", "match"),
    [(["--uncertainty", "mc", "--trials", "0"], "--trials"),
     (["--uncertainty", "mc", "--trials", "-5"], "--trials"),
     (["--uncertainty", "bayes"], "--uncertainty"),
     (["--uncertainty", "mc", "--seed", "-1"], "--seed")],
)
def test_bad_input_exits_2_with_one_line(files, kind, extra, match, capsys):
    code, out, err = _run([*files[kind], *extra], capsys)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith("accelcal: error:")
    assert match in err


@pytest.mark.parametrize("kind", ["head", "vre", "shaker"])
def test_type_b_option_needs_mc(files, kind, capsys):
    code, _, err = _run([*files[kind], *TYPE_B[kind]], capsys)
    assert code == 2
    assert "--uncertainty mc" in err


def test_head_mc_refuses_tumble(files, capsys):
    code, _, err = _run([*files["head"], "--method", "tumble", "--uncertainty", "mc"], capsys)
    assert code == 2
    assert "single, four and joint" in err
