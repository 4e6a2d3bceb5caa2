"""The package layering: imports run one way, down the pipeline, and the decoder uses only rollsim.protocol.

The layers live in ``pyproject.toml`` (``[tool.importlinter]``) and are
checked by import-linter; these tests run it, and check that every module
of rollsim has a layer, so a new one cannot slip past the contract.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import grimp
from importlinter.cli import lint_imports

ROOT = Path(__file__).parents[1]
PYPROJECT = ROOT / "pyproject.toml"
UNLAYERED = {"rollsim.__main__", "rollsim.bundled_scenes"}  # the entry point; scene files, no code


def _contracts() -> list[dict]:
    return tomllib.loads(PYPROJECT.read_text())["tool"]["importlinter"]["contracts"]


def test_import_linter_contracts_are_kept(monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    status = lint_imports(config_filename=str(PYPROJECT), no_cache=True, no_logo=True)
    assert status == 0, capsys.readouterr().out


def test_every_rollsim_module_has_a_layer():
    layers = next(c for c in _contracts() if c["type"] == "layers")["layers"]
    layered = {name.strip() for layer in layers for name in layer.split("|")}
    graph = grimp.build_graph("rollsim")
    top = {".".join(m.split(".")[:2]) for m in graph.modules if m.count(".") >= 1}
    assert top - layered - UNLAYERED == set()


def test_the_decoder_imports_only_rollsim_protocol():
    graph = grimp.build_graph("decoder", "rollsim")
    used = {imported for module in graph.find_children("decoder") | {"decoder"}
            for importer in graph.find_descendants(module) | {module}
            for imported in graph.find_modules_directly_imported_by(importer)
            if imported.startswith("rollsim")}
    assert used and all(m == "rollsim.protocol" or m.startswith("rollsim.protocol.") for m in used), sorted(used)


def test_a_backward_import_breaks_the_contract(tmp_path):
    # The contract is not vacuous: a copy of the project in which the
    # protocol imports the renderer fails it. A subprocess, so that the
    # copy's modules never enter this interpreter.
    copy = tmp_path / "project"
    shutil.copytree(ROOT / "rollsim", copy / "rollsim", ignore=shutil.ignore_patterns("__pycache__", "results"))
    shutil.copytree(ROOT / "decoder", copy / "decoder", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(PYPROJECT, copy / "pyproject.toml")
    frames = copy / "rollsim" / "protocol" / "frames.py"
    frames.write_text(frames.read_text() + "\nfrom rollsim.render import writer  # backward\n")
    run = subprocess.run(
        [sys.executable, "-c", "import sys; from importlinter.cli import lint_imports; "
                               "sys.exit(lint_imports(config_filename='pyproject.toml', no_cache=True, no_logo=True))"],
        cwd=copy, env={**os.environ, "PYTHONPATH": str(copy)}, capture_output=True, text=True, timeout=120,
    )
    assert run.returncode == 1, run.stdout + run.stderr
    assert "rollsim.protocol.frames -> rollsim.render" in run.stdout


def test_every_package_is_in_the_distribution():
    # setuptools' explicit package list: a package missing from it is absent
    # from a wheel (an editable install still finds it, which hid the gap).
    listed = set(tomllib.loads(PYPROJECT.read_text())["tool"]["setuptools"]["packages"])
    on_disk = {".".join(p.parent.relative_to(ROOT).parts) for root in ("rollsim", "decoder")
               for p in (ROOT / root).rglob("__init__.py")}
    assert on_disk - listed == set()
