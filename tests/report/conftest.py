"""The demo campaign, run once per test worker and shared by the report tests.

It is the suite's most expensive fixture (nine test methods simulated, reduced,
stored and reported, 25 figures drawn): the tests that read it share the xdist
group ``demo``, so that one worker runs it once (``--dist loadgroup`` in
pyproject.toml's addopts).
"""

import time
from types import SimpleNamespace

import pytest


@pytest.fixture(scope="session")
def demo_campaign(tmp_path_factory):
    """The demo (seed 3) in a temporary directory: ``result`` (the CampaignResult),
    ``db`` (its store) and ``cpu`` (the CPU seconds the run took)."""
    from accelcal.demo import run

    out = tmp_path_factory.mktemp("demo-campaign") / "demo"
    start = time.process_time()  # CPU time: wall time measures the machine's other load
    result = run(out, seed=3, progress=False)  # its store: records.sqlite inside out
    return SimpleNamespace(result=result, db=out / "records.sqlite",
                           cpu=time.process_time() - start)
