"""Running the command line in-process from tests: exit status, output, one-line errors."""

import pytest


def run_cli(args, capsys):
    """Run ``accelcal ARGS``; return (exit status, standard output, standard error)."""
    from accelcal.cli import main

    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in args])
    out, err = capsys.readouterr()
    return exc.value.code, out, err


def refused(args, capsys, *words):
    """The command exits 2 with one line (no traceback) that contains every word."""
    code, _, err = run_cli(args, capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    for word in words:
        assert word in err, err
    return err
