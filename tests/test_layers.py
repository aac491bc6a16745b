"""The package's architecture: layers that import one way, and no import cycle between modules.

The layers (top to bottom: cli, study, dynamics, film, case, errors) are a contract in pyproject.toml
checked by import-linter's ``lint-imports``; function-local imports count as imports. The cycle check
walks grimp's graph of the same package: a module that (directly or through others) imports itself
is a cycle, even inside one layer.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.serial


def test_layers_contract_is_kept():
    lint = Path(sys.executable).with_name("lint-imports")
    assert lint.exists(), "import-linter is missing: run scripts/setup.sh"
    done = subprocess.run([str(lint), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "1 kept, 0 broken" in done.stdout


def _graph():
    import grimp

    return grimp.build_graph("solver", cache_dir=None)


def _cycle(graph) -> list[str] | None:
    """One import cycle among the package's modules, or None (depth-first search, colours)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(module: str) -> list[str] | None:
        state[module] = 1
        stack.append(module)
        for imported in sorted(graph.find_modules_directly_imported_by(module)):
            if imported == "solver" or not imported.startswith("solver"):
                continue  # the root package holds only __version__
            if state.get(imported) == 1:
                return stack[stack.index(imported) :] + [imported]
            if imported not in state:
                found = visit(imported)
                if found:
                    return found
        stack.pop()
        state[module] = 2
        return None

    for module in sorted(graph.modules):
        if module not in state:
            found = visit(module)
            if found:
                return found
    return None


def test_no_import_cycle():
    graph = _graph()
    assert "solver.study.simulation" in graph.modules  # the graph is the package's
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_cycle_finder_finds_a_cycle():
    """The check can fail: a graph with a -> b -> a is reported."""
    import grimp

    graph = grimp.ImportGraph()
    for name in ("solver.a", "solver.b", "solver.c"):
        graph.add_module(name)
    graph.add_import(importer="solver.a", imported="solver.b")
    graph.add_import(importer="solver.b", imported="solver.c")
    assert _cycle(graph) is None
    graph.add_import(importer="solver.c", imported="solver.a")
    assert _cycle(graph) == ["solver.a", "solver.b", "solver.c", "solver.a"]


def test_the_film_value_types_import_no_dolfinx():
    """solver.film.types (Bearing, Kinematics, FilmResult, ...) is numpy only: the dynamics can describe
    a film's state without the finite-element stack; solver.film_rules too (the case loader's)."""
    import subprocess
    import sys

    code = (
        "import sys, solver.film.types, solver.film_rules, solver.film.spec, solver.film.history; "
        "print(sorted(m for m in ('dolfinx', 'petsc4py', 'gmsh', 'ufl') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
