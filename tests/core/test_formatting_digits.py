"""Numbers and units as the tables show them: digits a double holds, a unit's square."""

import pytest

from accelcal.cli import main
from accelcal.formatting import MAX_DIGITS, format_value, pm, unit_squared


def significant(text: str) -> int:
    """Significant digits of a formatted number (leading zeros, sign and exponent left out)."""
    mantissa = text.lower().split("e")[0].lstrip("-").replace(".", "")
    return len(mantissa.lstrip("0"))


@pytest.mark.parametrize(("value", "std"), [
    (0.000200000000000000037, 1.1e-20),   # a noise-free shaker fit: Ko
    (2.99999999999999465e-05, 4.5e-21),
    (-0.1000000000000000472, 9.5e-18),
    (1.0, 0.0 + 1e-300),
])
def test_a_standard_deviation_at_rounding_level_gives_no_more_digits_than_a_double_holds(
        value, std):
    text = format_value(value, std)
    assert significant(text) == MAX_DIGITS == 15, text
    assert float(text) == pytest.approx(value, rel=1e-14)


def test_the_noise_free_shaker_coefficient_reads_as_its_value():
    assert pm(0.000200000000000000037, 1.1e-20) == "0.000200000000000000 ± 1.1e-20"
    assert pm(0.200000000000000039, 1.1e-17) == "0.200000000000000 ± 1.1e-17"


@pytest.mark.parametrize(("value", "std", "text"), [
    (1.29936981234, 3e-8, "1.299369812"),       # digits down to a tenth of the SD
    (-624.3712, 0.8, "-624.37"),
    (1.0, 0.5, "1.00"),
    (123456.789, 1e-9, "123456.789000000"),      # 15 digits, not 17
])
def test_digits_follow_the_uncertainty_below_the_cap(value, std, text):
    assert format_value(value, std) == text


@pytest.mark.parametrize(("unit", "square"), [
    ("g", "g^2"), ("V", "V^2"), ("counts", "counts^2"), ("m/s^2", "(m/s^2)^2"),
    ("V/g", "(V/g)^2"), ("g^2", "(g^2)^2"),
])
def test_a_unit_squared_keeps_its_own_power(unit, square):
    assert unit_squared(unit) == square


def run(args, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    return out


def test_triad_detect_and_noise_psd_titles_square_the_unit_once(tmp_path, capsys):
    triad, still = tmp_path / "triad.csv", tmp_path / "still.csv"
    run(["triad", "simulate", "--positions", "six", "--out", triad], capsys)
    title = run(["triad", "detect", triad], capsys).splitlines()[0]
    assert "(m/s^2)^2 = 2 x the first" in title
    assert "^2^2" not in title
    run(["noise", "simulate", "--rate", "100", "--duration", "60", "--N", "2e-5",
         "--out", still], capsys)
    out = run(["noise", "psd", still, "--format", "table"], capsys)
    assert "^2^2" not in out
    assert "g^2/Hz)" in out
