"""Compiled kernels, where numba is installed and allowed; numpy otherwise.

The render's noise and readout stages work pixel by pixel. numpy needs a
full pass over the frame for every step of such a chain (a hash, a table
lookup, a clip, a rounding), while a compiled loop does the whole chain in
one pass. numba compiles a kernel the first time it runs and caches the
machine code on disk, so later processes (render workers, Dask workers) load
it instead of compiling again.

Every kernel has a numpy twin that performs the same IEEE-754 operations in
the same order on the same inputs, so the two give byte-identical results
(the tests compare them); numba is only ever a question of speed. numba is
not used when:

* it is not installed (``pip install rollsim`` installs it; a platform
  without a wheel falls back to numpy);
* the environment sets ``ROLLSIM_JIT=0``.

numba is imported only when a kernel is first asked for, so a command that
renders nothing never pays for the import.

numba's cache notices a change to a kernel's own file only, not to the
constants and modules it compiles in. rollsim therefore keeps its compiled
code in a cache directory named after a hash of every module that goes into
a kernel (:data:`KERNEL_SOURCES`): a changed or upgraded rollsim compiles
afresh instead of loading stale machine code. The directory is
``$NUMBA_CACHE_DIR/rollsim-<hash>`` where that variable is set, else under
``$XDG_CACHE_HOME`` (``~/.cache``), else the temporary directory.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import tempfile
from pathlib import Path
from typing import Any, Callable, Iterator, Optional

_DISABLED = ("0", "false", "no", "off")
# Every module whose code or constants a kernel compiles in.
KERNEL_SOURCES = ("rollsim.numerics.jit", "rollsim.numerics.counter_rng", "rollsim.numerics.gaussian", "rollsim.sensor.poisson",
                  "rollsim.sensor.chain", "rollsim.sensor.blooming", "rollsim.isp.jpeg_islow",
                  "rollsim.isp.filters", "rollsim.optics.motion", "rollsim.protocol.gf2",
                  "rollsim.numerics.ge_likelihood")


# Set by numpy_only(): work too short to pay for numba's import and cache load.
_numpy_only = False


def jit_wanted() -> bool:
    """Whether compiled kernels may run: ``ROLLSIM_JIT`` (default on), and not inside :func:`numpy_only`."""
    return not _numpy_only and os.environ.get("ROLLSIM_JIT", "1").strip().lower() not in _DISABLED


@contextlib.contextmanager
def numpy_only(active: bool = True) -> Iterator[None]:
    """Run the numpy twins inside this block (if ``active``): the same results.

    For work so short that importing numba and loading its cached machine
    code (about a second per process) would cost more than the numpy twins
    (a few hundred ms per 1080p frame): a one-frame render, say.
    """
    global _numpy_only
    before = _numpy_only
    _numpy_only = _numpy_only or active
    try:
        yield
    finally:
        _numpy_only = before


_numba: Any = None
_numba_checked = False


def numba_module() -> Optional[Any]:
    """The numba module, or None where it is not installed or not wanted."""
    global _numba, _numba_checked
    if not jit_wanted():
        return None
    if not _numba_checked:
        _numba_checked = True
        found: Any
        try:
            import numba as found
        except ImportError:  # numpy twins take over
            found = None
        if found is not None:
            found.config.CACHE_DIR = str(kernel_cache_dir())  # type: ignore[attr-defined]
        _numba = found
    return _numba


def sources_hash() -> str:
    """A hash of the files of :data:`KERNEL_SOURCES` (16 hex digits)."""
    digest = hashlib.sha256()
    for name in KERNEL_SOURCES:
        spec = importlib.util.find_spec(name)
        origin = spec.origin if spec is not None else None
        digest.update(name.encode())
        if origin:
            digest.update(Path(origin).read_bytes())
    return digest.hexdigest()[:16]


def kernel_cache_dir() -> Path:
    """Where compiled kernels are cached (see the module docstring); created if need be."""
    bases = [os.environ.get("NUMBA_CACHE_DIR"),
             os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "rollsim"),
             os.path.join(tempfile.gettempdir(), f"rollsim-numba-{os.getuid() if hasattr(os, 'getuid') else 0}")]
    name = f"rollsim-{sources_hash()}"
    for base in bases:
        if not base:
            continue
        path = Path(base) / name
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            return path
    return Path(tempfile.mkdtemp(prefix="rollsim-numba-"))


class Kernel:
    """A function compiled with numba on first use; None where numba is not used.

    Parameters
    ----------
    function : callable
        Plain Python over scalars and arrays, in numba's nopython subset,
        defined at module level (numba's on-disk cache keys on its file and
        name). It calls no other compiled function: numba passes array
        arguments to a called function with reference counting, which costs
        more than a kernel's per-pixel work, so a kernel is one flat body.
    """

    def __init__(self, function: Callable):
        self.function = function
        self._compiled: Any = None

    @property
    def compiled(self) -> Optional[Callable]:
        """The compiled function, or None (numba not used)."""
        numba = numba_module()
        if numba is None:
            return None
        if self._compiled is None:
            self._compiled = numba.njit(cache=True, nogil=True)(self.function)
        return self._compiled


def kernel(function: Callable) -> Kernel:
    """Decorator: a :class:`Kernel` of ``function``."""
    return Kernel(function)
