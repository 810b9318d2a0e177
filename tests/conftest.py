"""Fixtures shared across the test folders; the test tiers.

The default run (the README's command) leaves out the long tiers, marked
``slow`` (statistical checks against Monte Carlo), ``coverage`` (the
coverage harness, 400 experiments per case) and ``fuzz`` (the fuzzers'
matrices): ``pytest -m "slow or coverage or fuzz"`` runs them (.ci/run does,
after the default run). See "Tests" in the README.
"""

import os
import shutil
import subprocess

import pytest

POSTGRES_URL = os.environ.get("ACCELCAL_TEST_POSTGRES_URL")
"""A PostgreSQL server for the store tests (``.ci/postgres`` starts one), or None."""


@pytest.fixture(scope="session")
def postgres_url():
    """The PostgreSQL database of this test process (skipped where no server is given).

    Under pytest-xdist each worker has its own database (``accelcal_test_gw0``, ...,
    created on the server named by ``ACCELCAL_TEST_POSTGRES_URL``), since the ``db``
    fixture empties it before every test.
    """
    if not POSTGRES_URL:
        pytest.skip("no PostgreSQL: set ACCELCAL_TEST_POSTGRES_URL (.ci/postgres starts a server)")
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    if not worker:
        return POSTGRES_URL
    import sqlalchemy as sa

    url = sa.engine.make_url(POSTGRES_URL)
    name = f"{url.database}_{worker}"
    engine = sa.create_engine(url, isolation_level="AUTOCOMMIT")
    with engine.connect() as conn:
        query = sa.text("SELECT 1 FROM pg_database WHERE datname = :name")
        if conn.execute(query, {"name": name}).scalar() is None:
            conn.execute(sa.text(f'CREATE DATABASE "{name}"'))
    engine.dispose()
    return url.set(database=name).render_as_string(hide_password=False)


@pytest.fixture(params=["sqlite", "postgresql"])
def db(request, tmp_path):
    """A records store address: a new SQLite file; then PostgreSQL, emptied, where one is given.

    The PostgreSQL case is skipped unless ``ACCELCAL_TEST_POSTGRES_URL`` names a server.
    """
    if request.param == "sqlite":
        return str(tmp_path / "records.sqlite")
    url = request.getfixturevalue("postgres_url")
    import sqlalchemy as sa

    engine = sa.create_engine(url)
    with engine.begin() as conn:
        for table in ("journal", "coefficients", "calibrations", "schema_info"):
            conn.execute(sa.text(f"DROP TABLE IF EXISTS {table} CASCADE"))
    engine.dispose()
    return url


@pytest.fixture
def chromium(tmp_path):
    """Screenshots by Debian's headless ``chromium`` (skipped where it is not installed).

    The fixture is a function ``shoot(url, png, window="1100,1400", *flags)`` that renders
    ``url`` into the PNG file ``png`` with a fresh profile and returns the finished process
    (its standard error holds the page's console lines, ``CONSOLE``).
    """
    path = shutil.which("chromium")
    if path is None:
        pytest.skip("Debian's chromium is not installed")

    def shoot(url, png, window="1100,1400", *flags):
        return subprocess.run(
            [path, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
             "--no-first-run", "--disable-background-networking", "--disable-component-update",
             "--disable-sync", f"--user-data-dir={tmp_path / 'chromium-profile'}",
             f"--window-size={window}", *flags, "--enable-logging=stderr", "--v=0",
             f"--screenshot={png}", url],
            capture_output=True, text=True, timeout=120, check=False,
        )

    return shoot
