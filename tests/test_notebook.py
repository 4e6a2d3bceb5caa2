"""examples/tour.ipynb runs as a notebook user runs it: every cell in order, in a real kernel.

nbclient executes it in an ipykernel started for the test (in a temporary
working folder, so that nothing lands in the repository); a cell that
raises fails the test. The outputs are what a reader sees: the scene, the
result and the fit as tables (their ``_repr_html_``), the annotated frame
and the goodput curve as PNG images.
"""

from __future__ import annotations

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "tour.ipynb"


def _outputs(cell) -> set[str]:
    kinds = set()
    for output in cell.get("outputs", []):
        kinds.update(output.get("data", {}))
    return kinds


def test_the_tour_notebook_runs_and_shows_its_figures(tmp_path):
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    shown = {cell.source.splitlines()[-1]: _outputs(cell) for cell in code}
    assert "text/html" in shown["scene"] and "text/html" in shown["result"] and "text/html" in shown["fit"]
    assert "image/png" in shown["rs.show(next(iter(frames)), decoded=decoded)"]
    assert "image/png" in _outputs(code[-1])  # the goodput curve
    assert list(tmp_path.iterdir()) == []  # nothing written where it ran
