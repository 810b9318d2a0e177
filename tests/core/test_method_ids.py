"""Method ids of one pattern, ``<family>/<route>``, and old ids read as today's."""

import json

import numpy as np
import pytest

from accelcal.io.calibration_record import CalibrationRecord
from accelcal.method_ids import ALIASES, canonical, spellings
from accelcal.methods import REGISTRY
from accelcal.results import Estimate
from accelcal.store import Store


def _follows_pattern(method: str) -> bool:
    family, _, route = method.partition("/")
    return family in REGISTRY and bool(route) and "/" not in route


def test_every_alias_maps_an_old_id_to_one_of_the_pattern():
    for old, new in ALIASES.items():
        assert not _follows_pattern(old), old
        assert _follows_pattern(new), new
        assert new not in ALIASES
        assert canonical(old) == new
        assert canonical(new) == new
        assert spellings(old) == spellings(new)
        assert spellings(new)[0] == new
        assert old in spellings(new)
    assert spellings("dividing-head/joint") == ("dividing-head/joint",)


def test_the_method_constants_follow_the_pattern():
    import importlib

    from accelcal.methods.tumble import ROUTES as TUMBLE_ROUTES

    modules = ("centrifuge.reduce", "centrifuge.joint", "noise.fit", "noise.stability",
               "thermal.reduce", "triad.known", "triad.unknown", "vre.identify")
    for name in modules:
        method = importlib.import_module(f"accelcal.methods.{name}").METHOD
        assert _follows_pattern(method), method
        assert method.startswith(name.split(".")[0] + "/")
    assert {f"tumble-{r}" for r in TUMBLE_ROUTES if r != "auto"} <= set(ALIASES)


def test_reductions_carry_ids_of_the_pattern():
    from accelcal.methods.transverse import ROUTES
    from accelcal.methods.tumble import reduce_tumble

    theta = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    red = reduce_tumble(theta, 1.2 * (1e-4 + np.cos(theta) + 2e-5 * np.cos(theta) ** 2)
                        + 1e-7 * np.cos(5 * theta))
    assert red.method == "tumble/fourier"
    assert red.estimate.method == red.method
    assert {f"transverse-{r}" for r in ROUTES} <= set(ALIASES)


def _record(method, date="2026-01-01T00:00:00+00:00"):
    est = Estimate(("B", "N"), np.array([1e-6, 2e-5]), np.diag([1e-14, 1e-12]),
                   {"B": "g", "N": "g*sqrt(s)"}, method)
    return CalibrationRecord.from_estimate(est, serial="SN-1", date=date)


@pytest.mark.parametrize("old", sorted(ALIASES))
def test_a_record_file_with_an_old_id_reads_as_the_new_id(tmp_path, old):
    data = json.loads(_record("dividing-head/joint").to_json())
    data["method"] = old
    path = tmp_path / "old.json"
    path.write_text(json.dumps(data))
    assert CalibrationRecord.load(path).method == ALIASES[old]


def test_a_store_written_with_old_ids_shows_new_ids_and_filters_by_either(tmp_path):
    import sqlalchemy as sa

    db = str(tmp_path / "records.sqlite")
    store = Store(db)
    store.add(_record("noise/ieee952-fit", "2026-01-01T00:00:00+00:00"))
    store.add(_record("noise/ieee952-fit", "2026-02-01T00:00:00+00:00"))
    store.add(_record("dividing-head/joint", "2026-03-01T00:00:00+00:00"))
    # the first calibration as an older accelcal stored it
    with store.engine.begin() as conn:
        conn.execute(sa.text("UPDATE calibrations SET method = 'ieee952-fit' "
                             "WHERE date LIKE '2026-01%'"))
        assert conn.execute(sa.text("SELECT count(*) FROM calibrations "
                                    "WHERE method = 'ieee952-fit'")).scalar() == 1
    rows = store.calibrations("SN-1")
    assert [r["method"] for r in rows] == ["noise/ieee952-fit"] * 2 + ["dividing-head/joint"]
    assert store.calibrations_columns("SN-1")["method"] == [r["method"] for r in rows]
    for method in ("ieee952-fit", "noise/ieee952-fit"):
        history = store.history("SN-1", method)
        assert len(history) == 4
        assert {h["method"] for h in history} == {"noise/ieee952-fit"}
        b, _ = store.stats("SN-1", method)
        assert (b.method, b.name, b.n) == ("noise/ieee952-fit", "B", 2)
    assert len(store.history("SN-1")) == 6


def test_a_record_stored_under_its_old_id_is_not_added_twice(tmp_path):
    import hashlib

    import sqlalchemy as sa

    from accelcal.errors import AccelcalError

    record = _record("noise/ieee952-fit")
    store = Store(str(tmp_path / "records.sqlite"))
    store.add(record)
    # as an older accelcal stored it: the old id in the JSON and in the uid hashed from it
    old_text = record.to_json().replace('"method": "noise/ieee952-fit"', '"method": "ieee952-fit"')
    assert old_text != record.to_json()
    with store.engine.begin() as conn:
        conn.execute(sa.text("UPDATE calibrations SET method = 'ieee952-fit', uid = :uid, "
                             "record_json = :text"),
                     {"uid": hashlib.sha256(old_text.encode()).hexdigest(), "text": old_text})
    old_file = tmp_path / "old.json"
    old_file.write_text(old_text)
    with pytest.raises(AccelcalError, match="already in the store"):
        store.add(CalibrationRecord.load(old_file))
    assert len(store.calibrations("SN-1")) == 1


def test_records_history_accepts_an_old_id_on_the_command_line(tmp_path, capsys):
    from accelcal.cli import main

    db = str(tmp_path / "records.sqlite")
    Store(db).add(_record("thermal/wls"))
    for method in ("thermal-wls", "thermal/wls"):
        with pytest.raises(SystemExit) as info:
            main(["records", "history", "SN-1", "--db", db, "--method", method,
                  "--format", "json"])
        out, err = capsys.readouterr()
        assert info.value.code == 0, err
        assert {r["method"] for r in json.loads(out)} == {"thermal/wls"}


def test_the_module_examples_hold():
    import doctest

    import accelcal.method_ids

    result = doctest.testmod(accelcal.method_ids)
    assert result.attempted >= 2
    assert result.failed == 0
