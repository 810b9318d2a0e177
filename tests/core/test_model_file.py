"""Model files: JSON round trip, validation of bad files, atomic writing."""

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from accelcal import ErrorModel, default_model
from accelcal.errors import AccelcalError, ModelFileError
from accelcal.io.model_file import FORMAT_VERSION
from accelcal.model import TERMS

coef = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=50, deadline=None)
@given(
    values=st.fixed_dictionaries({name: coef for name in TERMS if name not in ("K1", "sigma")}),
    k1=coef.filter(lambda x: x != 0.0),
    sigma=st.floats(0.0, 1.0),
    unit=st.sampled_from(["V", "mV", "mA", "g"]),
)
def test_json_round_trip_is_exact(values, k1, sigma, unit):
    model = ErrorModel(**values, K1=k1, sigma=sigma, output_unit=unit)
    assert ErrorModel.from_json(model.to_json()) == model


def test_file_round_trip_and_content(tmp_path):
    path = tmp_path / "m.json"
    default_model().save(path)
    assert ErrorModel.load(path) == default_model()
    data = json.loads(path.read_text())
    assert data["format_version"] == FORMAT_VERSION
    assert data["units"]["K1"] == "V/g"
    assert list(data["coefficients"]) == list(TERMS)


def test_missing_terms_default_to_zero():
    text = json.dumps({"format_version": 1, "kind": "accelcal.ErrorModel",
                       "output_unit": "mA", "coefficients": {"K1": 1.2, "K2": 1e-6}})
    assert ErrorModel.from_json(text) == ErrorModel(K1=1.2, K2=1e-6, output_unit="mA")


def _file(**changes):
    data = default_model().to_dict()
    for key, value in changes.items():
        if value is None:
            del data[key]
        else:
            data[key] = value
    return json.dumps(data)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{not json", r"not valid JSON \(line 1, column 2"),
        ("[1, 2]", "expected a JSON object"),
        (_file(extra=1), "unknown key\\(s\\) 'extra'"),
        (_file(kind=None), "missing key\\(s\\) 'kind'"),
        (_file(kind="something.else"), "kind is 'something.else'"),
        (_file(format_version=99), "format_version 99 is newer"),
        (_file(format_version="1"), "format_version must be an integer"),
        (_file(output_unit="uV"), "output_unit 'uV' is not one of"),
        (_file(coefficients={"K1": 1.0, "Kxx": 2.0}), "coefficients: unknown term 'Kxx'"),
        (_file(coefficients={"K1": 1.0, "K2": "1e-6"}), "coefficients.K2 must be a number"),
        (_file(coefficients={"K2": 1e-6}), "coefficients.K1 .* is missing"),
        (_file(coefficients={"K1": 0.0}), "K1 \\(scale factor\\) is 0"),
        (_file(coefficients=[1, 2]), "coefficients must be an object"),
        (_file(units={"K1": "mV/g"}), "units.K1 is 'mV/g' but a model with output_unit 'V'"),
        (_file(units={"Kzz": "g"}), "units: unknown term 'Kzz'"),
        (
            (
                '{"format_version": 1, "kind": "accelcal.ErrorModel", "output_unit": "V", '
                '"coefficients": {"K1": 1.0, "K2": NaN}}'
            ),
            "NaN is not allowed",
        ),
    ],
)
def test_bad_files_give_clear_errors(tmp_path, text, message):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(ModelFileError, match=message) as info:
        ErrorModel.load(path)
    assert str(path) in str(info.value)


def test_missing_file_says_how_to_create_one(tmp_path):
    with pytest.raises(ModelFileError, match="not found; create one with 'accelcal model new'"):
        ErrorModel.load(tmp_path / "absent.json")


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    path = tmp_path / "m.json"

    def boom(self, *args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr("pathlib.Path.write_text", boom)
    with pytest.raises(AccelcalError, match=r"cannot write .*m.json: disk full"):
        default_model().save(path)
    assert list(tmp_path.iterdir()) == []


def test_text_is_stable():
    text = default_model().to_json()
    assert ErrorModel.from_json(text).to_json() == text
