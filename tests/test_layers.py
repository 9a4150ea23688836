"""The library's folders are its layers (issue 31): each imports only the layers below it, and no
module imports in a circle, imports inside functions counted.

The contracts are ``[tool.importlinter]`` in ``pyproject.toml``, checked by import-linter (its
import graph, from grimp, holds every import statement of a module: at module level, inside
functions and under ``if TYPE_CHECKING``).  From the top: ``book`` (plotting, tables, the
chapters' helpers), ``analyses``, ``model``, ``description``, ``numerics``, then the root's
``cache`` and ``errors``.  The planted tests run the same contracts on a copy of the package
with one upward import, or one cycle, written inside a function: each must break the check.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import fivebar

ROOT = Path(__file__).resolve().parents[1]
LIB = Path(fivebar.__file__).parent
LINT = ("import sys; from importlinter.cli import lint_imports; "
        "sys.exit(lint_imports(config_filename=sys.argv[1], no_cache=True, no_logo=True))")


def _lint(lib: Path) -> subprocess.CompletedProcess:
    """import-linter with the project's contracts on the package ``fivebar`` found in ``lib``."""
    env = dict(os.environ, PYTHONPATH=str(lib))
    return subprocess.run([sys.executable, "-c", LINT, str(ROOT / "pyproject.toml")], capture_output=True,
                          text=True, env=env, cwd=lib, timeout=600)


def test_the_layers_hold_and_no_module_imports_in_a_circle():
    out = _lint(LIB.parent)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert "2 kept, 0 broken" in out.stdout, out.stdout[-2000:]


def test_every_module_is_in_a_layer():
    """Below ``fivebar`` there are only the layers (a new module goes into one of them)."""
    layers = {"book", "analyses", "model", "description", "numerics", "cache", "errors"}
    top = {p.stem for p in LIB.glob("*.py") if p.stem != "__init__"}
    top |= {p.name for p in LIB.iterdir() if (p / "__init__.py").is_file()}
    assert top == layers, top ^ layers
    config = (ROOT / "pyproject.toml").read_text()
    assert all(f'"fivebar.{name}"' in config for name in layers)


def _planted(tmp_path: Path, module: str, line: str) -> subprocess.CompletedProcess:
    """The contracts on a copy of the package whose ``module`` (a path below fivebar) has a
    function holding the import ``line``."""
    lib = tmp_path / "lib"
    shutil.copytree(LIB, lib / "fivebar", ignore=shutil.ignore_patterns("__pycache__", "data"))
    path = lib / "fivebar" / module
    path.write_text(path.read_text() + f"\n\ndef _planted():\n    {line}\n")
    return _lint(lib)


def test_an_upward_import_inside_a_function_breaks_the_layers(tmp_path):
    out = _planted(tmp_path, "numerics/schemes.py", "from ..book.plotting import response_plot")
    assert out.returncode != 0
    assert "fivebar.numerics.schemes -> fivebar.book.plotting" in out.stdout, out.stdout[-3000:]


def test_a_cycle_inside_a_layer_breaks_the_check(tmp_path):
    """response is below steady (steady imports it); response importing steady closes a circle."""
    out = _planted(tmp_path, "analyses/response.py", "from .steady import shooting")
    assert out.returncode != 0
    assert "No cycles are allowed in fivebar.analyses" in out.stdout, out.stdout[-3000:]
