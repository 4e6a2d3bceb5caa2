"""Helpers for tests that run rollsim as a user would: a real process, real files."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

# A small render: fast enough for tests that start several processes.
SMALL = ["--set", "camera.width_px=160", "--set", "camera.height_px=120", "--set", "camera.row_time_us=200"]
GIB = 1 << 30


@dataclass
class Finished:
    """A finished rollsim process."""

    returncode: int
    stdout: str
    stderr: str
    seconds: float

    @property
    def err_lines(self) -> list[str]:
        return self.stderr.splitlines()


def _limits(address_space: int | None, file_size: int | None):
    def apply():
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))
        if file_size is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size, file_size))

    return apply


def rollsim_env(**extra) -> dict:
    """The environment of a rollsim process: this one's, without a memory limit set by the caller."""
    env = {k: v for k, v in os.environ.items() if k != "ROLLSIM_MEMORY_LIMIT"}
    env.update(extra)
    return env


def start_rollsim(*args, cwd, address_space=None, file_size=None, **env) -> subprocess.Popen:
    """Start ``python -m rollsim ARGS`` in ``cwd`` (optionally under rlimits)."""
    return subprocess.Popen(
        [sys.executable, "-m", "rollsim", *map(str, args)], cwd=cwd, env=rollsim_env(**env),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=_limits(address_space, file_size),
    )


def run_rollsim(*args, cwd, address_space=None, file_size=None, timeout=120, **env) -> Finished:
    """Run ``python -m rollsim ARGS`` to the end."""
    start = time.perf_counter()
    process = start_rollsim(*args, cwd=cwd, address_space=address_space, file_size=file_size, **env)
    out, err = process.communicate(timeout=timeout)
    return Finished(process.returncode, out, err, time.perf_counter() - start)


def tree_state(root: Path) -> dict:
    """Every entry under ``root`` (hidden ones too): size, mode and modification time."""
    state = {}
    for path in sorted(Path(root).rglob("*")):
        info = path.lstat()
        state[path.relative_to(root).as_posix()] = (info.st_size if path.is_file() else None, info.st_mode,
                                                    info.st_mtime_ns)
    return state


def assert_one_error(result, code: int, *fragments: str) -> str:
    """Exit ``code``, exactly one line on stderr holding every fragment, no traceback."""
    err = result.stderr if hasattr(result, "stderr") else result
    assert "Traceback" not in err, err
    lines = err.splitlines()
    assert len(lines) == 1, lines
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    if hasattr(result, "returncode"):
        assert result.returncode == code, (result.returncode, lines)
    return lines[0]


def wait_for(predicate, timeout: float = 60.0, step: float = 0.02) -> None:
    """Poll ``predicate`` until it is true; fail after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError("timed out waiting")
        time.sleep(step)


def staging_areas(parent: Path) -> list[Path]:
    return sorted(p for p in Path(parent).iterdir() if p.name.endswith(".staging"))


def descendants(pid: int) -> list[int]:
    """Processes whose parent chain leads to ``pid`` (Linux /proc)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            ppid = int(stat[stat.rfind(")") + 2 :].split()[1])
            children.setdefault(ppid, []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie counts as dead)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rfind(")") + 2] != "Z"
