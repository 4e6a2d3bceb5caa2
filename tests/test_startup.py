"""Start-up: ``rollsim describe`` and ``rollsim render`` import only what they use.

Checked by what a fresh interpreter has imported once it has run both
commands, not by a clock. colour-science (with the matplotlib and pandas it
imports), scipy.stats and scipy.signal each took a second or more of every
command's start-up; rollsim reads V(λ) and the illuminants' photons per
lumen from tables instead. Any part of SciPy 1.17 costs about 0.3 s more
(its array-API layer imports numpy.testing and numpy.f2py): the normal
tables are computed by AS241 (rollsim.numerics.gaussian) and the Poisson tables'
log-factorials by cephes' own formulas (rollsim.sensor.special), the
glare's convolution runs on scipy.fft's compiled module loaded alone, and
only ``describe --json`` and RLNC scenes predict the rlnc figures with
scipy.special's negative binomial. numba is loaded by long renders
only, tqdm only to show a bar.
"""

from __future__ import annotations

import json
import subprocess
import sys

from clitools import SMALL

UNUSED = ("colour", "matplotlib", "pandas", "pyarrow", "scipy", "numba", "tqdm", "numpy.testing", "numpy.f2py")

# paper-default lists ambient light (an illuminant), glare (a convolution)
# and Poisson shot noise (log-factorials), and describe's text predicts RP.
PROGRAM = """
import json, sys
from rollsim.cli import main
small = {small!r}
assert main(["describe", "paper-default", *small]) == 0
assert main(["render", "paper-default", "--frames", "1", "--quiet", "--out", "out", *small]) == 0
unused = {unused!r}
print(json.dumps(sorted(n for n in sys.modules if any(n == u or n.startswith(u + ".") for u in unused))))
"""


def test_describe_and_render_do_not_import_what_they_do_not_use(tmp_path):
    program = PROGRAM.format(small=SMALL, unused=UNUSED)
    done = subprocess.run([sys.executable, "-c", program], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == []


# What loading the commands' modules may not import: the heavy modules are
# imported inside the functions that need them (a glare's convolution, an
# rlnc prediction, a compiled kernel, a progress bar, a plot; `rollsim run`'s
# calibration and plots, imported while its workers render).
IMPORT_PROGRAM = """
import json, sys
import rollsim.cli, rollsim.stages.describe, rollsim.render.pipeline, rollsim.scene, rollsim.channel.eventsim
import rollsim.report.run
unused = {unused!r}
print(json.dumps(sorted(n for n in sys.modules if any(n == u or n.startswith(u + ".") for u in unused))))
"""


def test_loading_the_command_modules_imports_no_heavy_module(tmp_path):
    unused = (*UNUSED, "cv2")
    done = subprocess.run([sys.executable, "-c", IMPORT_PROGRAM.format(unused=unused)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == []


# ``describe --json`` lists every strategy's figures: rlnc's negative
# binomial is scipy.special's (its bits), never scipy.stats.
JSON_PROGRAM = """
import json, sys
from rollsim.cli import main
assert main(["describe", "paper-default", "--json"]) == 0
print(json.dumps(sorted(n for n in sys.modules if n.startswith(("scipy.stats", "scipy.signal", "numba")))))
"""


def test_describe_json_imports_only_scipy_special(tmp_path):
    done = subprocess.run([sys.executable, "-c", JSON_PROGRAM], cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == []
