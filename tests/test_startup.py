"""Start-up: ``rollsim describe`` and ``rollsim render`` import only what they use.

Checked by what a fresh interpreter has imported once it has run both
commands, not by a clock. colour-science (with the matplotlib and pandas it
imports), scipy.stats and scipy.signal each took a second or more of every
command's start-up; rollsim reads V(λ) and the illuminants' photons per
lumen from tables, the negative binomial from scipy.special and the glare's
convolution from scipy.fft instead (the tests of each check the same bits).
"""

from __future__ import annotations

import json
import subprocess
import sys

from clitools import SMALL

UNUSED = ("colour", "matplotlib", "pandas", "pyarrow", "scipy.stats", "scipy.signal")

# paper-default lists ambient light (an illuminant) and glare (a convolution),
# and describe predicts the rlnc figures (a negative binomial).
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
