"""One idea per module (issue 17, point 5): every module imports alone, the library's
module-level imports form no cycle, and the model's code names no part of the paper's five-bar
(its links L1..L5, its motor sections motor1, motor2): those live in the data files
(``fivebar/data/*.toml``) and the chapters' text.

References: the import system itself (a fresh import of each module, the package's modules
removed from ``sys.modules`` before each) and the modules' syntax trees.
"""

from __future__ import annotations

import ast
import pytest
import io
import re
import subprocess
import sys
import tokenize
from pathlib import Path

import fivebar

LIB = Path(fivebar.__file__).parent
#: Every module of the package below ``fivebar`` as a dotted name ("numerics.newmark"), the
#: subpackages' own ``__init__`` as the subpackage ("numerics").
MODULES = sorted(".".join(p.relative_to(LIB).with_suffix("").parts).removesuffix(".__init__")
                 for p in LIB.rglob("*.py") if p != LIB / "__init__.py")

#: The model (parameters, description, kinematics, rigid and elastic model, the equation of
#: motion, modes, excitation, the response), the control model's free-rotor linkage and the
#: analyses (steady states, branches, sweeps, resonance, multiple scales, Figure 6's tables, the
#: multibody model, control): the code that must work from any description (issue 34).
MODEL = ("description.params", "description.linkage", "description.setup", "model.kinematics", "model.rigid",
         "model.elements", "model.electromagnetics", "model.assembly", "model.nonlinear", "model.dynamics",
         "analyses.modal", "model.excitation", "analyses.response", "model.free_rotors", "analyses.steady",
         "analyses.branches", "analyses.sweep", "analyses.resonance", "analyses.linkage_multiscale",
         "analyses.figure6", "analyses.multibody", "analyses.control.control_model",
         "analyses.control.control_design", "analyses.control.control_simulation", "analyses.sensitivity")
#: A name of the paper's five-bar in code: a link L1..L5 or a motor section motor1, motor2.
FIVE_BAR = re.compile(r"\b(L[1-5]|motor[12])\b")


@pytest.mark.slow
def test_every_module_imports_alone():
    """Each module imported first, in a process where no other module of the package is loaded
    yet (third-party modules stay cached, so one process serves): an import cycle fails here."""
    code = (
        "import importlib, sys\n"
        f"mods = {MODULES!r}\n"
        "bad = []\n"
        "for m in mods:\n"
        "    for k in [k for k in sys.modules if k == 'fivebar' or k.startswith('fivebar.')]:\n"
        "        del sys.modules[k]\n"
        "    try:\n"
        "        importlib.import_module('fivebar.' + m)\n"
        "    except Exception as exc:\n"
        "        bad.append((m, repr(exc)))\n"
        "print(bad); assert not bad, bad\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]


def _path(name: str) -> Path:
    """The file of the module ``name`` (dotted, below ``fivebar``)."""
    p = LIB.joinpath(*name.split("."))
    return p / "__init__.py" if p.is_dir() else p.with_suffix(".py")


def _module_imports(name: str) -> set[str]:
    """The package's modules that ``name`` imports at module level (not inside functions)."""
    path = _path(name)
    tree = ast.parse(path.read_text())
    package = ["fivebar", *name.split(".")[:None if path.name == "__init__.py" else -1]]
    out: set[str] = set()
    for node in tree.body:
        nodes = [node]
        if isinstance(node, ast.Try):  # optional imports
            nodes = node.body + [h for x in node.handlers for h in x.body]
        for n in nodes:
            if isinstance(n, ast.ImportFrom) and n.level:
                base = package[:len(package) - (n.level - 1)][1:]
                target = ".".join(base + ([n.module] if n.module else []))
                out |= {target} if n.module else {".".join(base + [a.name]) for a in n.names}
    return out & set(MODULES)


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for k in sorted(graph[m]):
            if state.get(k) == 1:
                return stack[stack.index(k):] + [k]
            if k not in state and (found := visit(k)):
                return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (found := visit(m)):
            return found
    return None


def test_module_level_imports_form_no_cycle():
    graph = {m: _module_imports(m) for m in MODULES}
    assert graph["numerics.newmark"] >= {"numerics.schemes", "numerics.systems"}  # the integrator uses the two halves it was split from
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))
    assert _cycle({"a": {"b"}, "b": {"a"}}) == ["a", "b", "a"]  # the check finds a planted cycle


def _code_names(source: str) -> list[tuple[int, str]]:
    """Names and string literals of the code (docstrings and comments left out) that name a
    part of the paper's five-bar."""
    tree = ast.parse(source)
    doc: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                doc |= set(range(body[0].lineno, body[0].end_lineno + 1))
        # attribute docstrings (a string statement after an assignment)
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            doc |= set(range(node.lineno, node.end_lineno + 1))
    hits = []
    kinds = {tokenize.NAME, tokenize.STRING} | {getattr(tokenize, "FSTRING_MIDDLE", tokenize.STRING)}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type in kinds and tok.start[0] not in doc and FIVE_BAR.search(tok.string):
            hits.append((tok.start[0], tok.string))
    return hits


def test_the_model_names_no_part_of_the_five_bar():
    found = {m: _code_names(_path(m).read_text()) for m in MODEL}
    assert not any(found.values()), {m: h for m, h in found.items() if h}
    # the data file names them (the description says which links and motors there are)
    assert "motor1" in (LIB / "data" / "wang2011.toml").read_text()
    # and the check sees a planted name, in code but not in a docstring or comment
    planted = '"""Doc of L2 and motor1."""\n# L3\nJ = params.motors["motor1"]\nlink = "L2"\n'
    assert _code_names(planted) == [(3, '"motor1"'), (4, '"L2"')]


def test_every_source_file_compiles_without_a_warning():
    """An escape like ``\\m`` of ``\\mathbf`` in a docstring that is not raw is a
    DeprecationWarning today and a SyntaxWarning from Python 3.12 (an error in a later one);
    the docstring shows the backslash only by luck.  Every source file (the package, the tests,
    the book's extensions, the benchmarks) compiles with warnings as errors."""
    import warnings
    root = LIB.parent.parent
    files = [p for d in (LIB, root / "tests", root / "book" / "_ext", root / "benchmarks") for p in sorted(d.rglob("*.py"))]
    bad = []
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                compile(path.read_text(encoding="utf-8"), str(path), "exec", dont_inherit=True)
            except (SyntaxError, DeprecationWarning, SyntaxWarning) as exc:
                bad.append(f"{path.relative_to(root)}: {exc}")
    assert not bad, "\n".join(bad)
