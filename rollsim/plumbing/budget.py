"""The memory and disk budgets: refuse an input before it allocates or writes more than the machine has.

Every input that sets a size (message bytes, emission counts, M and N, the
frame size, a PNG's declared dimensions, a file read whole) is turned into an
estimate of the bytes it will allocate, and checked here *before* the
allocation. Over the budget, :func:`check_memory` raises a
:class:`rollsim.errors.BudgetError` whose one line names the field and the
estimate.

The budget is, in order of precedence:

1. ``rollsim --memory-limit SIZE`` (which sets the variable below, so that
   worker processes see it too);
2. the environment variable ``ROLLSIM_MEMORY_LIMIT`` (``2G``, ``500M``,
   ``1.5GiB`` or a byte count);
3. half of the memory available to this process: the least of the free
   memory (``MemAvailable``), the cgroup's remaining limit and the room left
   under the address-space limit (``ulimit -v``).

The disk budget works the same way for what a command writes (frames, truth,
a sweep's kept frames): :func:`check_disk` compares an estimate with
``rollsim --disk-limit SIZE``, else ``ROLLSIM_DISK_LIMIT``, else the free
space of the target's file system less a margin (:func:`disk_margin_bytes`),
before the first byte is written. A disk that fills anyway (another program
writing meanwhile) still stops the command cleanly (:mod:`rollsim.plumbing.outputs`).
"""

from __future__ import annotations

import os
import re
import resource
import stat
from pathlib import Path
from typing import Optional

from rollsim.errors import BudgetError, RollsimError

ENV_VAR = "ROLLSIM_MEMORY_LIMIT"
DISK_ENV_VAR = "ROLLSIM_DISK_LIMIT"
# Left free on the target's file system: a disk filled to the last byte
# stops every other program on the machine too. 5 % of the file system,
# at most 1 GiB.
DISK_MARGIN_FRACTION = 0.05
DISK_MARGIN_MAX_BYTES = 2**30
_UNITS = {"": 1, "B": 1, "K": 10**3, "M": 10**6, "G": 10**9, "T": 10**12,
          "KI": 2**10, "MI": 2**20, "GI": 2**30, "TI": 2**40}
_SIZE = re.compile(r"^\s*([0-9]+(?:\.[0-9]*)?|\.[0-9]+)\s*([KMGT]I?)?B?\s*$", re.IGNORECASE)


def parse_size(text: str, name: str = ENV_VAR) -> int:
    """Bytes of a size such as ``2G``, ``500M``, ``1.5GiB`` or ``123456``.

    Decimal prefixes (K = 1000) and binary ones (Ki = 1024) are both accepted.

    Raises
    ------
    RollsimError
        Not a size, or zero.
    """
    match = _SIZE.match(str(text))
    if not match:
        raise RollsimError(f"{name} = {str(text)[:40]!r}: expected a size such as 2G, 500M or a byte count")
    number, unit = match.groups()
    value = int(float(number) * _UNITS[(unit or "").upper()])
    if value < 1:
        raise RollsimError(f"{name} = {str(text)[:40]!r}: must be at least 1 byte")
    return value


def format_bytes(n_bytes: float) -> str:
    """``n_bytes`` in the largest decimal unit that keeps it >= 1 (``7.6 GB``)."""
    value = float(n_bytes)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(value) < 1000 or unit == "PB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.3g} {unit}"
        value /= 1000
    return f"{value:.3g} EB"  # pragma: no cover


def _meminfo_available() -> Optional[int]:
    try:
        text = Path("/proc/meminfo").read_text()
    except OSError:
        return None
    match = re.search(r"^MemAvailable:\s+(\d+) kB", text, re.MULTILINE)
    return int(match.group(1)) * 1024 if match else None


def _cgroup_room() -> Optional[int]:
    """Bytes left under this process's cgroup v2 memory limit, if it has one."""
    try:
        group = Path("/proc/self/cgroup").read_text().strip().split("::", 1)[-1]
        base = Path("/sys/fs/cgroup") / group.lstrip("/")
        limit = (base / "memory.max").read_text().strip()
        if limit == "max":
            return None
        return max(0, int(limit) - int((base / "memory.current").read_text()))
    except (OSError, ValueError):
        return None


def _address_space_room() -> Optional[int]:
    """Bytes of address space left under ``RLIMIT_AS``, if it is set."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY:
        return None
    try:
        text = Path("/proc/self/status").read_text()
    except OSError:
        text = ""
    match = re.search(r"^VmSize:\s+(\d+) kB", text, re.MULTILINE)
    used = int(match.group(1)) * 1024 if match else 0
    return max(0, soft - used)


def available_bytes() -> int:
    """Memory this process can still allocate: the least of every known limit."""
    known = [v for v in (_meminfo_available(), _cgroup_room(), _address_space_room()) if v is not None]
    if not known:
        pages = os.sysconf("SC_AVPHYS_PAGES") if hasattr(os, "sysconf") else 0
        known = [pages * os.sysconf("SC_PAGE_SIZE")] if pages > 0 else [2**33]
    return min(known)


def memory_budget_bytes() -> int:
    """The budget: ``ROLLSIM_MEMORY_LIMIT`` if set, else half of :func:`available_bytes`."""
    text = os.environ.get(ENV_VAR, "").strip()
    if text:
        return parse_size(text)
    return max(1, available_bytes() // 2)


def check_memory(what: str, estimate_bytes: float) -> None:
    """Refuse ``what`` if it needs more than the budget.

    Parameters
    ----------
    what : str
        The input that sets the size, as the user wrote it, e.g.
        ``"link.message_bytes = 10000000 (with header_bits = 32)"``.
    estimate_bytes : float
        Bytes the work would allocate at its peak.

    Raises
    ------
    BudgetError
        One line naming ``what``, the estimate and the budget.
    """
    budget = memory_budget_bytes()
    if estimate_bytes > budget:
        source = f"{ENV_VAR}" if os.environ.get(ENV_VAR, "").strip() else "half the available memory"
        raise BudgetError(
            f"{what}: needs about {format_bytes(estimate_bytes)}, more than the memory budget of "
            f"{format_bytes(budget)} ({source}; raise it with --memory-limit or {ENV_VAR})"
        )


def check_file_size(path: Path, bytes_per_file_byte: float, what: str = "") -> None:
    """Refuse to read ``path`` whole if its parsed form would exceed the budget.

    A device, pipe or socket (``/dev/zero``) has no size to check and may
    never end: it is refused too.

    Parameters
    ----------
    path : Path
    bytes_per_file_byte : float
        Memory the parsed content takes per byte of file (Python objects
        from JSON lines take about 10).
    what : str, optional
        How to name the file; default its path.
    """
    try:
        info = Path(path).stat()
    except OSError:
        return  # the reader reports a missing or unreadable file itself
    if not stat.S_ISREG(info.st_mode) and not stat.S_ISDIR(info.st_mode):
        raise RollsimError(f"{what or path}: not a regular file (a device, pipe or socket cannot be read whole)")
    check_memory(f"{what or path} ({format_bytes(info.st_size)})", info.st_size * bytes_per_file_byte)


def existing_ancestor(path: Path) -> Path:
    """``path`` or the nearest directory above it that exists (where its bytes will land)."""
    path = Path(os.path.abspath(path))
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


def disk_margin_bytes(total_bytes: int) -> int:
    """Bytes left free on a file system of ``total_bytes``: 5 %, at most 1 GiB."""
    return int(min(DISK_MARGIN_MAX_BYTES, DISK_MARGIN_FRACTION * total_bytes))


def disk_budget_bytes(target: Path) -> tuple[int, str]:
    """The bytes a command may write under ``target``, and where that figure comes from.

    ``ROLLSIM_DISK_LIMIT`` if set, else the free space of ``target``'s file
    system (the nearest existing directory's) less :func:`disk_margin_bytes`.
    """
    text = os.environ.get(DISK_ENV_VAR, "").strip()
    if text:
        return parse_size(text, DISK_ENV_VAR), f"set by --disk-limit or {DISK_ENV_VAR}"
    where = existing_ancestor(target)
    try:
        info = os.statvfs(where)
    except OSError:  # nothing to measure: the write itself will say what is wrong
        return 2**63, "free space unknown"
    free = info.f_bavail * info.f_frsize
    margin = disk_margin_bytes(info.f_blocks * info.f_frsize)
    return max(0, free - margin), (f"the free space on {where} less {format_bytes(margin)}; "
                                   f"set a budget with --disk-limit or {DISK_ENV_VAR}")


def check_disk(what: str, estimate_bytes: float, target: Path) -> None:
    """Refuse to write ``estimate_bytes`` under ``target`` if they exceed the disk budget.

    Parameters
    ----------
    what : str
        The inputs that set the size, as the user wrote them, e.g.
        ``"--frames 1000000000 of 1920 x 1080 gray8"``.
    estimate_bytes : float
        Bytes the command will write (an upper bound).
    target : Path
        Where they go (it need not exist yet).

    Raises
    ------
    BudgetError
        One line naming ``what``, the estimate and the budget.
    """
    budget, source = disk_budget_bytes(Path(target))
    if estimate_bytes > budget:
        raise BudgetError(
            f"{what}: would write about {format_bytes(estimate_bytes)}, more than the disk budget of "
            f"{format_bytes(budget)} ({source})"
        )
