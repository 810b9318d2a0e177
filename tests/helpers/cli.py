"""Running the command line in-process from tests: exit status, output, one-line errors."""

import json
from pathlib import Path

import pytest


def run_cli(args, capsys):
    """Run ``accelcal ARGS``; return (exit status, standard output, standard error)."""
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return exc.value.code, out, err


def run(capsys, *args):
    """Run ``accelcal *ARGS`` (the hardening modules' spelling of :func:`run_cli`)."""
    return run_cli(args, capsys)


def refused(args, capsys, *words):
    """The command exits 2 with one line (no traceback) that contains every word."""
    code, _, err = run_cli(args, capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    for word in words:
        assert word in err, err
    return err


def assert_one_line_error(code, err, *needles):
    """Exit status 2 and one short ``accelcal: error:`` line, no traceback, every needle in it."""
    assert code == 2
    assert err.startswith("accelcal: error: ")
    assert err.count("\n") == 1
    assert "Traceback" not in err
    assert len(err) < 600
    for needle in needles:
        assert needle in err


def leftovers(directory: Path) -> list[str]:
    """Temporary files (``*.tmp``) left in ``directory``: an atomic write leaves none."""
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(".tmp"))


def unstated_uncertainty(stdout: str) -> str | None:
    """A JSON output's fitted coefficient whose uncertainty is missing (JSON writes a
    non-finite number as null: an infinite or NaN std would pass as "no value")."""
    try:
        doc = json.loads(stdout)
    except ValueError:
        return None
    stack = [doc]
    while stack:
        node = stack.pop()
        if isinstance(node, list):
            stack.extend(node)
        elif isinstance(node, dict):
            if node.get("status") == "fitted" and "std" in node and node["std"] is None:
                return (f"exit 0 with fitted {node.get('coefficient')} = {node.get('estimate')} "
                        "and no finite std (null in JSON)")
            stack.extend(v for v in node.values() if isinstance(v, list | dict))
    return None
