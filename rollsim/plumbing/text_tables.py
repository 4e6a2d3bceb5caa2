"""Tables and numbers as text: plain-text tables for the terminal, Markdown
tables for reports and the docs, the number formats they share, and the
objects of the Python API shown by their key figures (:class:`Shown`: a
one-line repr, and a small HTML table in a notebook)."""

from __future__ import annotations

from rollsim.errors import clip


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


# ------------------------------------------------------ objects as figures

# The most characters of one figure's value in a repr (a path, a name).
FIGURE_CHARS = 80


class Shown:
    """An object shown by its key figures: its repr is one line of them, and
    a notebook shows them as a small HTML table (``_repr_html_``).

    A class gives :meth:`_figures`, read from what the object already holds:
    nothing is rendered, decoded or read from disk to show it. Neither repr
    raises (a repr that raises breaks a notebook's output): where
    :meth:`_figures` fails, the class name alone is shown.
    """

    def _figures(self) -> tuple[str, list[tuple[str, object]]]:
        """A title (``""`` for none) and the ``(label, value)`` pairs to show."""
        raise NotImplementedError

    def _shown(self) -> tuple[str, str, list[tuple[str, str]]]:
        """The class name, the title and the figures as one-line texts; the class name alone if they fail."""
        kind = type(self).__name__
        try:
            title, figures = self._figures()
            return kind, _one_line(title), [(_one_line(label), _one_line(value)) for label, value in figures]
        except Exception:  # a half-built or damaged object still shows what it is
            return kind, "", []

    def __repr__(self) -> str:
        kind, title, figures = self._shown()
        head = f"{kind} {title}" if title else kind
        return f"<{head}: {', '.join(f'{label} {value}' for label, value in figures)}>" if figures else f"<{head}>"

    def __str__(self) -> str:
        # pydantic's str lists every field; the figures say more in a line.
        return repr(self)

    def _repr_html_(self) -> str:
        import html

        kind, title, figures = self._shown()
        caption = html.escape(f"{kind} {title}" if title else kind)
        rows = "".join(f"<tr><th style=\"text-align:left\">{html.escape(label)}</th>"
                       f"<td style=\"text-align:left\">{html.escape(value)}</td></tr>" for label, value in figures)
        return f"<table><caption>{caption}</caption>{rows}</table>"


def _one_line(value) -> str:
    """``value`` as one line of at most :data:`FIGURE_CHARS` characters."""
    text = figure_number(value) if isinstance(value, float) else str(value)
    return clip(" ".join(text.split()), FIGURE_CHARS)


def figure_number(value, digits: int = 4) -> str:
    """A number to ``digits`` significant digits, a whole one in full (``5000``, not ``5e+03``)."""
    value = float(value)
    return str(int(value)) if value.is_integer() and abs(value) < 1e15 else f"{value:.{digits}g}"


def quantity(value, unit: str) -> str:
    """A figure with its unit: ``27.8 µs``; ``n/a`` for None."""
    return "n/a" if value is None else f"{figure_number(value)} {unit}"
