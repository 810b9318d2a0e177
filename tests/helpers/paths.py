"""The repository's directories, for tests wherever they sit under ``tests/``."""

from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
"""The ``tests/`` directory (on the test run's import path: ``helpers`` lives here)."""

ROOT = TESTS.parent
"""The repository's root (README.md, docs/, examples/, benchmarks/)."""

FIXTURES = TESTS / "fixtures"
"""Committed test inputs: a version-1 calibration record, real recordings."""

REAL_IMUCAL = FIXTURES / "real" / "imucal"
"""imucal's own six-position session (real data, see its README)."""

EXAMPLES = ROOT / "examples" / "data"
"""The committed example files that examples/make_data.py writes."""
