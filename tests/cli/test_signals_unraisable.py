"""A signal taken inside a finaliser (where an exception cannot pass) still ends the run."""

import subprocess
import sys

SCRIPT = """
import os, signal, time
from accelcal.cli import signals

signals.install()

class Finaliser:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(100000):  # the handler runs here, inside the finaliser
            pass

try:
    Finaliser()
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        pass
    print("not interrupted")
except signals.Interrupted as exc:
    print("interrupted", exc.signum)
"""


def test_an_interrupt_inside_a_finaliser_is_delivered_again():
    done = subprocess.run([sys.executable, "-c", SCRIPT], check=False, capture_output=True,
                          text=True, timeout=30)
    assert "Exception ignored" not in done.stderr, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert done.stdout.strip() == "interrupted 2", (done.stdout, done.stderr)
