"""The shape of the code (issue 11): arrows one way, no import circle, no private name across modules,
each name imported from the module that defines it, no module over ~400 lines, installed names that cannot clash.

Read from the source files with ``ast``, imports inside functions included (those under
``if TYPE_CHECKING:`` are for annotations only and are left out).
"""

from __future__ import annotations

import ast
import tomllib
from functools import cache
from pathlib import Path

import networkx as nx
import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"evidential": "evidential", "evmap.sources": "sources", "evmap.maps": "maps", "evmap.configs": "configs"}
"""Installed package -> its folder in the repo (``pyproject.toml``'s ``package-dir``)."""

MAX_LINES = 420
"""No module over ~400 lines."""

FACADES = {"evmap.sources.evidence", "evmap.sources.sim.scenario"}
"""Modules that still hand on names of others (the source kinds' specs, the scenario's limits): imports from
them are not checked yet."""


@cache
def modules() -> dict[str, Path]:
    """Every module of the installed packages, by dotted name."""
    found = {}
    for package, folder in PACKAGES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = [p for p in path.relative_to(ROOT / folder).with_suffix("").parts if p != "__init__"]
            found[".".join([package, *parts])] = path
    return found


@cache
def tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), str(path))


def type_checking_only(module: ast.Module) -> set[int]:
    """The ids of the nodes under ``if TYPE_CHECKING:``."""
    return {
        id(sub)
        for node in ast.walk(module)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
        for sub in ast.walk(node)
    }


def resolve(name: str) -> str | None:
    """The project module that ``name`` (a module, or a name in one) is in."""
    while name and name not in modules():
        name = name.rpartition(".")[0]
    return name or None


def imported(module: str) -> set[str]:
    """The project modules that ``module`` imports at run time, wherever the import statement stands."""
    path = modules()[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    skip = type_checking_only(tree(path))
    out = set()
    for node in ast.walk(tree(path)):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # from . import x, from ..y import z
                above = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join([*above, base] if base else above)
            names = [f"{base}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in modules():
            names = [node.value]  # import_module("..."), the lazy homes of a package's names
        else:
            continue
        out |= {r for r in map(resolve, names) if r and r != module}
    return out


@cache
def import_graph() -> nx.DiGraph:
    graph = nx.DiGraph()
    for module in modules():
        graph.add_node(module)
        graph.add_edges_from((module, other) for other in imported(module))
    return graph


def test_no_import_circle():
    cycles = [" -> ".join([*c, c[0]]) for c in nx.simple_cycles(import_graph())]
    assert cycles == []


@pytest.mark.parametrize(
    ("lower", "upper"),
    [("evidential", "evmap."), ("evmap.sources", "evmap.maps"), ("evmap.configs", "evmap.")],
)
def test_arrows_point_one_way(lower, upper):
    """``evmap.maps.app -> evmap.maps -> evmap.sources -> evidential``: nothing below imports what is above."""
    wrong = [
        (a, b)
        for a, b in import_graph().edges
        if a.startswith(lower) and b.startswith(upper) and not b.startswith(lower)
    ]
    assert wrong == []


def test_the_map_does_not_import_the_application():
    wrong = [
        (a, b)
        for a, b in import_graph().edges
        if a.startswith("evmap.maps") and not a.startswith("evmap.maps.app") and b.startswith("evmap.maps.app")
    ]
    assert wrong == []


def private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def own_names(module: ast.Module) -> set[str]:
    """Every name a file binds itself: functions, classes, arguments, variables, attributes it assigns."""
    names = set()
    for node in ast.walk(module):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, (ast.Store, ast.Del)):
            names.add(node.attr)
    return names


def source_files() -> list[Path]:
    return [p for folder in (*PACKAGES.values(), "tests", "benchmarks") for p in sorted((ROOT / folder).rglob("*.py"))]


def test_no_private_name_across_modules():
    """No ``from m import _x``, and no ``obj._x`` unless the file itself defines ``_x`` (its own class's
    attribute); private names of the standard library and third parties are not the project's to judge."""
    found = []
    for path in source_files():
        module = tree(path)
        own = own_names(module)
        outside = {
            (a.asname or a.name).split(".")[0]
            for node in ast.walk(module)
            if isinstance(node, ast.Import)
            for a in node.names
            if a.name.split(".")[0] not in ("evidential", "evmap")
        }
        for node in ast.walk(module):
            if isinstance(node, ast.ImportFrom):
                found += [f"{path.relative_to(ROOT)}:{node.lineno}: {a.name}" for a in node.names if private(a.name)]
            elif isinstance(node, ast.Attribute) and private(node.attr) and node.attr not in own:
                root = node.value
                while isinstance(root, ast.Attribute):
                    root = root.value
                namedtuple_api = node.attr in ("_replace", "_asdict", "_fields", "_make")
                if not namedtuple_api and getattr(root, "id", None) not in outside:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert found == []


def defined(module: str) -> set[str]:
    """The names a module binds at its top level other than by importing them."""
    names = set()
    for node in tree(modules()[module]).body:
        targets = []
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        elif isinstance(node, (ast.If, ast.Try, ast.For, ast.With)):
            names |= {n.name for n in ast.walk(node) if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
            targets = [node]
        names |= {
            n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)
        }
    return names


def test_each_name_is_imported_from_the_module_that_defines_it():
    """One way to import each name: not through a module that imports it too (packages' ``__init__`` aside,
    which are the documented entry points)."""
    found = []
    for path in source_files():
        for node in ast.walk(tree(path)):
            if not (isinstance(node, ast.ImportFrom) and node.module in modules()):
                continue
            if modules()[node.module].name == "__init__.py" or node.module in FACADES:
                continue
            where = path.relative_to(ROOT).as_posix()
            for a in node.names:
                submodule = f"{node.module}.{a.name}" in modules()
                if not submodule and a.name not in defined(node.module):
                    found.append(f"{where}:{node.lineno}: {a.name} from {node.module}")
    assert found == []


def test_no_module_over_about_400_lines():
    lines = {path.relative_to(ROOT).as_posix(): len(path.read_text().splitlines()) for path in modules().values()}
    too_long = {name: n for name, n in lines.items() if n > MAX_LINES}
    assert too_long == {}


def test_installed_import_names_cannot_clash():
    """What is installed is ``evidential`` and the rest under ``evmap.``: no top-level ``maps``, ``sources``,
    ``configs``."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert all(p == "evidential" or p.startswith("evmap.") for p in setuptools["packages"])
    assert {k: v for k, v in setuptools["package-dir"].items() if not k.startswith("evmap.")} == {}
    assert set(PACKAGES) - {"evidential"} <= set(setuptools["package-dir"])
