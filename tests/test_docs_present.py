"""README.md and docs/ state the present; history goes to CHANGELOG.md.

A page that names a commit ("at 590e925", "the decoder of commit 36b8805")
or speaks of "before this change" or "the last stop" is telling history.
That belongs in CHANGELOG.md; the pages give today's behaviour and today's
figures, each with the command that measures it.

A commit id is a word of 7 to 40 lowercase hex digits holding at least one
letter a-f and one digit, not part of a longer word, number, file name or
hex literal. Values a page shows as a program prints them, in quotes (the
16-hex-digit run id in docs/evaluation.md's `evaluate` message), and hex
colours (`#a0b1c2d3`) are not commit ids.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

COMMIT_ID = re.compile(
    r"(?<![\w#-])(?<!\w\.)"          # not inside a word, a hex colour, a file name
    r"(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])"  # a letter and a digit
    r"[0-9a-f]{7,40}"
    r"(?![\w-])(?!\.\w)"             # nor continued by one
)
QUOTED = re.compile(r"""(['"])[0-9a-f]+\1""")
PHRASES = re.compile(r"\b(before this change|the last stop|at commit)\b", re.IGNORECASE)


def history_in(text: str) -> list[str]:
    """Commit ids and history phrases in ``text``, as ``line N: match``."""
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        shown = QUOTED.sub("", line)
        found += [f"line {number}: {m.group(0)}" for m in COMMIT_ID.finditer(shown)]
        found += [f"line {number}: {m.group(0)!r}" for m in PHRASES.finditer(line)]
    return found


def test_pages_exist():
    assert (ROOT / "README.md").exists() and len(PAGES) > 10


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_page_states_the_present(page):
    found = history_in(page.read_text(encoding="utf-8"))
    assert not found, f"{page.relative_to(ROOT)} tells history (move it to CHANGELOG.md): {found}"


@pytest.mark.parametrize("text", [
    "`rollsim paper --out DIR` at a19f2f5, with the refitted emitter",
    "the decoder of commit 36b8805: before its second look",
    "(commit 590e925, see [Stripe SNR](#stripe-snr))",
    "19.8 min at 43dfcc6.",
    "https://github.com/o/r/commit/0123456789abcdef0123456789abcdef01234567",
    "as it was before this change",
    "The Last Stop measured 5 ms",
    "re-measured at commit 1234567",
])
def test_history_is_found(text):
    assert history_in(text)


@pytest.mark.parametrize("text", [
    "another render (this directory's is '6b69b9c9258576da')",
    'run = "0000000000000000abc1"',
    "a colour #a0b1c2d3 and #abc123",
    "0x1f2e3d4c5b and 12345678 and 1e10 and deadbeef and 2.5e-7",
    "sha256 " + "ab12" * 16,
    "frame_000000.png, cafe123.png, v1.2.3abcdef, x-abc1234",
    "the cells committed before are kept; staging, commit and replacement",
])
def test_present_is_not_flagged(text):
    assert history_in(text) == []
