"""Background imports (rollsim.plumbing.preload): modules loaded on a thread, failures left to the real import."""

import subprocess
import sys

from rollsim.plumbing.preload import Preload, preloading

PROGRAM = """
import sys
from rollsim.plumbing.preload import preloading
with preloading(["json.tool", "rollsim_no_such_module", "colorsys"]) as preload:
    assert "json.tool" not in sys.modules  # nothing before start()
    preload.start()
    preload.start()  # once
print("json.tool" in sys.modules, "colorsys" in sys.modules)
"""


def test_the_modules_load_in_order_and_a_failure_stops_quietly(tmp_path):
    done = subprocess.run([sys.executable, "-c", PROGRAM], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    # json.tool loaded; the missing module stopped the thread before colorsys; nothing printed on stderr.
    assert done.stdout.split() == ["True", "False"]
    assert done.stderr == ""


def test_join_without_start_returns_at_once():
    preload = Preload(["json"])
    preload.join()
    with preloading([]) as empty:
        empty.start()
    assert empty.modules == ()
