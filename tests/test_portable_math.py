"""rollsim.numerics.portable_math against the C library, and the render's bits on every level of the CPU's SIMD.

numpy's exp, log, power and arcsin, and OpenCV's float filters, take the
widest SIMD code the CPU offers, and the levels round differently. numpy
and OpenCV can be told to leave levels out (NPY_DISABLE_CPU_FEATURES,
OPENCV_CPU_DISABLE): a process that uses only the baseline stands for an
older machine, and renders the same frames.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from rollsim.numerics import portable_math as pm

from clitools import SMALL


def ulps(got: np.ndarray, expected: np.ndarray) -> np.ndarray:
    """|got − expected| in units of the last place of ``expected``."""
    return np.abs(got - expected) / np.spacing(np.abs(expected))


def c_library(function, x) -> np.ndarray:
    return np.array([function(float(v)) for v in np.ravel(x)])


RNG = np.random.default_rng(20261125)


def test_exp_is_within_an_ulp_of_the_c_librarys():
    x = np.concatenate([RNG.uniform(-708, 709.7, 100_000), RNG.uniform(-1, 1, 50_000), RNG.uniform(-1e-8, 1e-8, 1000),
                        np.arange(-40.0, 5.0, 0.001)])
    assert ulps(pm.exp(x), c_library(math.exp, x)).max() <= 1.0


def test_exp_below_the_normal_range_is_within_a_subnormal_step():
    x = RNG.uniform(-745.0, -708.5, 10_000)
    assert np.abs(pm.exp(x) - c_library(math.exp, x)).max() <= 5e-324


def test_log_is_within_an_ulp_of_the_c_librarys():
    x = np.concatenate([pm.exp(RNG.uniform(-744, 709, 100_000)), RNG.uniform(0.5, 2.0, 100_000),
                        np.arange(1.0, 3e6, 29.0), [5e-324, 1e-310, 1.0, 2.0, np.nextafter(1.0, 0.0)]])
    expected = c_library(math.log, x)
    exact = expected == 0.0
    assert np.array_equal(pm.log(x)[exact], expected[exact])
    assert ulps(pm.log(x)[~exact], expected[~exact]).max() <= 1.0


def test_arcsin_is_within_2_ulp_of_the_c_librarys():
    x = np.concatenate([RNG.uniform(-1, 1, 200_000), RNG.uniform(-1e-6, 1e-6, 1000),
                        [-1.0, 1.0, 0.5, -0.5, np.nextafter(0.5, 1.0), np.nextafter(1.0, 0.0), 1e-300]])
    assert ulps(pm.arcsin(x), c_library(math.asin, x)).max() <= 2.0
    assert pm.arcsin(np.array([0.0, -0.0])).tobytes() == np.array([0.0, -0.0]).tobytes()


@pytest.mark.parametrize(("y", "bound"), [(-2.0, 1), (-1.5, 2), (-1.0, 1), (0.5, 1), (2.0, 1), (3.0, 1), (4.0, 2),
                                          (-4.0, 3), (3.5, 3), (-3.5, 4), (-2.5, 3)])
def test_power_by_products_is_within_its_roundings(y, bound):
    x = RNG.uniform(0.01, 100.0, 50_000)
    assert ulps(pm.power(x, y), c_library(lambda v: math.pow(v, y), x)).max() <= bound


@pytest.mark.parametrize("y", [1 / 2.4, 1 / 2.2, -1.7, 2.2, -3.3, 4.5, -6.0])
def test_power_through_exp_and_log_is_within_its_bound(y):
    # The error grows with |y·ln x|: about 16 ulp at y = 2.2, x = 100.
    x = RNG.uniform(0.0, 100.0, 50_000)
    bound = 4.0 + 2.0 * abs(y) * math.log(100.0)
    assert ulps(pm.power(x, y), c_library(lambda v: math.pow(v, y), x)).max() <= bound


def test_special_values_and_shapes():
    assert pm.exp(np.array([np.inf, -np.inf, np.nan, 710.0, -746.0, 0.0])).tolist()[:2] == [np.inf, 0.0]
    got = pm.exp(np.array([np.nan, 710.0, -746.0, 0.0]))
    assert np.isnan(got[0]) and got[1:].tolist() == [np.inf, 0.0, 1.0]
    got = pm.log(np.array([0.0, -1.0, np.inf, np.nan, 1.0]))
    assert got[0] == -np.inf and np.isnan(got[1]) and got[2] == np.inf and np.isnan(got[3]) and got[4] == 0.0
    assert np.isnan(pm.arcsin(np.array([1.5, -2.0, np.nan]))).all()
    assert pm.power(np.array([0.0, 4.0, -1.0]), -2.0)[:2].tolist() == [np.inf, 0.0625]
    assert np.isnan(pm.power(np.array([-1.0]), 0.3)).all()
    assert pm.power(np.array([0.0, 0.0]), 0.3).tolist() == [0.0, 0.0] and pm.power(np.zeros(1), 0.0).tolist() == [1.0]
    for function in (pm.exp, pm.log, pm.arcsin):
        big = RNG.uniform(0.1, 0.9, (300, 250))  # more than one piece
        out = function(big)
        assert out.shape == big.shape and out.dtype == np.float64
        assert out.tobytes() == np.concatenate([function(row) for row in big]).tobytes()
    assert pm.exp(np.float32(1.5)).shape == () and pm.exp([1.0, 2.0]).shape == (2,)
    with pytest.raises(ValueError, match="exponent"):
        pm.power(np.ones(2), np.nan)
    # Past float64's range: inf and 0, and no warning (pytest turns RuntimeWarnings into errors).
    assert pm.power(np.array([1e200, 1e300]), 2.0).tolist() == [np.inf, np.inf]
    assert pm.power(np.array([1e-155, 1e-78]), -4.0).tolist() == [np.inf, np.inf]
    assert pm.power(np.array([1e300]), -1.5).tolist() == [0.0]


@given(st.floats(min_value=-700.0, max_value=700.0))
def test_exp_of_any_float_is_within_an_ulp(x):
    assert ulps(pm.exp(np.array([x])), np.array([math.exp(x)]))[0] <= 1.0


@given(st.floats(min_value=1e-300, max_value=1e300))
def test_log_of_any_float_is_within_an_ulp(x):
    expected = math.log(x)
    got = pm.log(np.array([x]))[0]
    assert got == expected or ulps(np.array([got]), np.array([expected]))[0] <= 1.0


# ----------------------------------------------------- every level of SIMD
#
# Scenes whose render took a CPU-dependent path before: glare (power,
# complex product), the ISP (tone curve's power, OpenCV's float filters),
# dark-current non-uniformity (exp), a lens PSF (exp), a first-order LED
# (exp), spectral channels (the LED's spectrum), the disk's exact coverage
# (arcsin) in all of them.
SCENES = ("paper-default", "effect-isp", "effect-row_noise", "effect-blur", "effect-led_rise_time", "effect-bayer",
          "effect-defocus", "stress-strong-ambient")

PROGRAM = """
import hashlib, json, sys
import numpy as np
from rollsim.numerics import portable_math as pm
from rollsim.render import RenderPipeline
from rollsim.scene import load_scene

def digest(*arrays):
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()

x = np.random.default_rng(7).uniform(0.01, 0.99, 100_000)
out = {"numpy_log": digest(np.log(x)), "portable": digest(pm.exp(x), pm.log(x), pm.arcsin(x), pm.power(x, 1 / 2.4))}
for name in sys.argv[2:]:
    pipeline = RenderPipeline(load_scene(name, json.loads(sys.argv[1])))
    out[name] = digest(*(pipeline.render(i).image for i in range(2)))
print(json.dumps(out))
"""

# OpenCV's names of the levels above SSE 4.2 (unknown names are ignored with a warning).
OPENCV_LEVELS = "AVX512-SKX,AVX512-ICL,AVX512-CLX,AVX512-CNL,AVX2,FMA3,AVX,FP16"


def _run(environment: dict[str, str], tmp_path) -> dict[str, str]:
    overrides = [item for item in SMALL if item != "--set"]
    done = subprocess.run([sys.executable, "-c", PROGRAM, json.dumps(overrides), *SCENES], capture_output=True,
                          text=True, timeout=300, cwd=tmp_path, env={**os.environ, **environment})
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.fixture(scope="module")
def full_and_baseline(tmp_path_factory):
    umath = np._core._multiarray_umath
    dispatched = [name for name in umath.__cpu_dispatch__ if umath.__cpu_features__.get(name)]
    tmp = tmp_path_factory.mktemp("simd")
    full = _run({}, tmp)
    baseline = _run({"NPY_DISABLE_CPU_FEATURES": " ".join(dispatched), "OPENCV_CPU_DISABLE": OPENCV_LEVELS}, tmp)
    return full, baseline, dispatched


def test_renders_and_functions_have_the_same_bits_with_the_baseline_simd_only(full_and_baseline):
    full, baseline, _ = full_and_baseline
    assert {k: v for k, v in full.items() if k != "numpy_log"} == {k: v for k, v in baseline.items() if k != "numpy_log"}


def test_the_baseline_process_does_round_numpys_log_differently(full_and_baseline):
    # What makes the test above a test: on a CPU with SIMD logarithms the
    # two processes do run different code.
    full, baseline, dispatched = full_and_baseline
    if full["numpy_log"] == baseline["numpy_log"]:
        pytest.skip(f"this CPU's numpy log is the baseline's at every level it has ({dispatched})")
    assert full["numpy_log"] != baseline["numpy_log"]
