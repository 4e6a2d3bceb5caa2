"""Tables and numbers as text: plain-text tables for the terminal, Markdown
tables for reports and the docs, and the number formats they share."""

from __future__ import annotations


def format_number(value, digits: int = 4) -> str:
    """``value`` to ``digits`` significant digits; ``n/a`` for None."""
    return "n/a" if value is None else f"{value:.{digits}g}"


def format_percent(value, decimals: int = 3) -> str:
    """A fraction as a percentage with ``decimals`` decimals; ``n/a`` for None."""
    return "n/a" if value is None else f"{100 * value:.{decimals}f} %"


def format_table(rows: list[tuple], header: tuple) -> str:
    """A plain-text table with aligned columns."""
    cells = [tuple(str(c) for c in header)] + [tuple(str(c) for c in row) for row in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(row, widths)) for row in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def markdown_table(rows: list[tuple], header: tuple) -> list[str]:
    """The lines of a Markdown table."""
    lines = ["| " + " | ".join(str(c) for c in header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
