"""Helpers shared by the test modules (and by ``benchmarks/coverage.py``).

``tests/`` is on the import path of the test run (``pythonpath`` in
pyproject.toml), so a test module writes ``from helpers.cli import run_cli``:

:mod:`helpers.paths`
    The repository's directories: fixtures, example data, docs.
:mod:`helpers.cli`
    Running ``accelcal`` in-process; one-line errors.
:mod:`helpers.records`
    Calibration records made for the store tests.
:mod:`helpers.contract`
    The reduction contract every method passes.
:mod:`helpers.coverage`
    The coverage harness: are the stated uncertainties honest?
:mod:`helpers.daq_files`
    Small DAQ files written by the real libraries.
"""
