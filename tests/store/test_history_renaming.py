"""One coefficient across its renaming (K_F, then K_F+K_OO) in the history and the report."""

import numpy as np
import pytest

from accelcal.cli import main
from accelcal.identifiability import combination_name, plain_name
from accelcal.io.calibration_record import CalibrationRecord
from accelcal.report.sections import coefficient_stats, history_section
from accelcal.results import Estimate
from accelcal.store import Store
from accelcal.store.history import renamings
from helpers.records import make_record


@pytest.mark.parametrize(("name", "plain"), [
    ("K0+Kpp", "K0"), ("K2-Kpp", "K2"), ("K_F+K_OO", "K_F"), ("K_II-K_OO", "K_II"),
    ("Ko-Kop", "Ko"), ("K3+0.5*K1_asym", "K3"), ("K3+1e-05*K1_asym", "K3"),
    ("K1", "K1"), ("K1_T1", "K1_T1"), ("K0_asym", "K0_asym")])
def test_plain_name_inverts_the_combination_name(name, plain):
    assert plain_name(name) == plain


def test_plain_name_of_every_combination_name():
    for shares in ({"Kpp": 1.0}, {"Kpp": -1.0, "K1_asym": 0.25}, {"K_OO": 2.5e-7}):
        assert plain_name(combination_name("K_F", shares)) == "K_F"


def _renamed(serial="SN-7"):
    """Two calibrations recorded as K_F, then two as K_F+K_OO (the rows renamed)."""
    old = [make_record(serial=serial, date=f"2026-0{m}-01T00:00:00+00:00", shift=m * 1e-6)
           for m in (1, 2)]
    new = []
    for m in (3, 4):
        est = Estimate(("K_F", "K_I", "K_O"), np.array([-8.3e-4, 1.2993698, -1.2e-5]) + m * 1e-6,
                       np.diag([1.0e-12, 4.0e-12, 9.0e-12]),
                       {"K_F": "V", "K_I": "V/g", "K_O": "V"}, "dividing-head/joint")
        rec = CalibrationRecord.from_estimate(
            Estimate(("K_F+K_OO", "K_I", "K_O"), est.values, est.covariance,
                     {"K_F+K_OO": "V", "K_I": "V/g", "K_O": "V"}, "dividing-head/joint"),
            serial=serial, date=f"2026-0{m}-01T00:00:00+00:00")
        new.append(rec)
    return old + new


def test_history_groups_a_renamed_coefficient_and_states_the_change(tmp_path, capsys):
    store = Store(str(tmp_path / "s.sqlite"))
    for rec in _renamed():
        store.add(rec)
    rows = store.history("SN-7")
    assert {r["coefficient"] for r in rows if r["name"].startswith("K_F")} == {"K_F"}
    assert {r["name"] for r in rows if r["coefficient"] == "K_F"} == {"K_F", "K_F+K_OO"}
    assert store.history_columns("SN-7")["coefficient"] == [r["coefficient"] for r in rows]
    (change,) = renamings(rows)
    assert (change.coefficient, change.before, change.after) == ("K_F", "K_F", "K_F+K_OO")
    assert change.date.startswith("2026-03-01")
    assert renamings(store.history_columns("SN-7")) == [change]
    # the repeatability is taken across the change: one coefficient with 4 calibrations
    stats = {s.name: s for s in coefficient_stats(rows)}
    assert stats["K_F"].n == 4
    assert "K_F+K_OO" not in stats
    assert stats["K_F"].repeatability == pytest.approx(np.std([1, 2, 3, 4], ddof=1) * 1e-6)
    section = history_section(store, "SN-7")
    by_name = {r["coefficient"]: r for r in section.rows}
    assert by_name["K_F"]["calibrations"] == 4
    assert by_name["K_F"]["recorded as"] == "K_F then K_F+K_OO"
    assert "recorded as K_F+K_OO from 2026-03-01" in section.summary
    store.close()
    with pytest.raises(SystemExit) as exc:
        main(["records", "history", "SN-7", "--db", str(tmp_path / "s.sqlite"), "--format",
              "csv"])
    out, err = capsys.readouterr()
    assert exc.value.code == 0
    assert out.splitlines()[0].endswith(",coefficient")
    assert sum(line.endswith(",K_F") for line in out.splitlines()) == 4
    assert "note: K_F (dividing-head/joint) is recorded as K_F+K_OO from 2026-03-01" in err


def test_history_figure_draws_one_panel_per_plain_coefficient(tmp_path):
    from accelcal.plotting.records import history_figure

    store = Store(str(tmp_path / "s.sqlite"))
    for rec in _renamed():
        store.add(rec)
    fig = history_figure(store.history("SN-7"), "SN-7")
    store.close()
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["K_F (V)", "K_I (V/g)", "K_O (V)"]
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert "recorded as K_F+K_OO from here" in texts
    assert "recorded as K_F" in texts


def test_without_renaming_the_stats_are_the_stores(tmp_path):
    store = Store(str(tmp_path / "s.sqlite"))
    for m in (1, 2, 3):
        store.add(make_record(date=f"2026-0{m}-01T00:00:00+00:00", shift=m * 1e-6))
    assert coefficient_stats(store.history("SN-1")) == store.stats("SN-1")
    assert renamings(store.history("SN-1")) == []
    store.close()
