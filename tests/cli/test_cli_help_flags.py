"""Every command's help: a flag shows no value type, an option that takes a value shows one."""

import re

import pytest
import typer

from accelcal.cli import main
from accelcal.cli.app import app

TYPE = re.compile(r"<[\w|\[\], ]+>")
"""A value type as the help shows it: ``<float>``, ``<path>``, ``<bool>``."""


def command_paths() -> list[tuple[list[str], object]]:
    """Every group and command of the application with its path of names (the root first)."""
    found = []

    def walk(cmd, path):
        found.append((path, cmd))
        for name, sub in getattr(cmd, "commands", {}).items():
            walk(sub, [*path, name])

    walk(typer.main.get_command(app), [])
    return found


def help_text(path, capsys) -> str:
    with pytest.raises(SystemExit) as exc:
        main([*path, "--help"])
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    return out


def option_line(text: str, option: str) -> str:
    """The help line that starts with ``option`` (inside the options panel)."""
    lines = [line for line in text.splitlines() if re.match(rf"^│\W*{option}\b", line)]
    assert lines, f"{option} not in\n{text}"
    return lines[0]


def test_no_help_shows_a_type_for_a_flag(monkeypatch, capsys):
    monkeypatch.setenv("COLUMNS", "200")
    paths = command_paths()
    assert len(paths) > 40
    flags = 0
    for path, cmd in paths:
        text = help_text(path, capsys)
        assert "<bool>" not in text, " ".join(path)
        for param in cmd.params:
            if getattr(param, "is_flag", False) and not param.hidden:
                flags += 1
                line = option_line(text, param.opts[0])
                assert not TYPE.search(line), line
        assert "--help" in option_line(text, "--help")
    assert flags > 10


def test_an_option_with_a_value_still_shows_its_type(monkeypatch, capsys):
    monkeypatch.setenv("COLUMNS", "200")
    text = help_text(["transverse", "sweep"], capsys)
    assert "<float>" in option_line(text, "--frequency")
    assert "<path>" in option_line(text, "--plot")
    assert not TYPE.search(option_line(text, "--summary"))
