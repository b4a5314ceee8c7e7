"""The import architecture: which package of synthcal may import which (issue 13).

Every module under ``synthcal/`` is parsed (not imported) and each of its imports of
synthcal — at module level, inside functions, under ``TYPE_CHECKING``, absolute or
relative (``from . import x``, ``from ..generate import render``) — is checked
against :data:`CONTRACT`. A failure lists every offending import with its file and
line. The packages must also form no import cycle.

Private names stay in their module (issue 21): no file under ``synthcal/``,
``tests/`` or ``benchmarks/`` imports or reaches for a ``_name`` of another synthcal
module (:func:`private_uses_in` says what counts).

The contract, package by package (a package may always import its own modules):

* ``config``, ``models``, ``utils`` import nothing of synthcal;
* ``store`` → config, utils; ``data`` → config, store;
* ``scenes`` → config, utils (the OSM scene cache writes its PNGs with ``utils.atomic``);
* ``generate`` → config, scenes, store, utils;
* ``training`` → models, data, store, config, utils;
* ``estimators`` → models, data, store, training, config, utils;
* ``eval`` → estimators, data, store, config, utils, viz, scenes (for the colours), and
  of ``generate`` only the renderer and the camera (``generate.render``, ``generate.camera``);
* ``viz`` → ``scenes`` only;
* ``cli`` and ``api`` (the Python front door's facade functions) → anything;
* the top-level ``synthcal/__init__.py`` → ``api``, and the modules its
  ``TYPE_CHECKING`` block names for mypy (``data.loaders``, ``estimators.protocol``).
  It imports none of them when it runs: its ``__getattr__`` imports a public name on
  first use (PEP 562), and the parser sees the ``TYPE_CHECKING`` imports like any
  other, so they are allowed here — and nothing else.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TOP = "synthcal"

TOP_LEVEL = ""  # the package name of the top-level __init__.py


@dataclass(frozen=True)
class Rule:
    """What one package may import: whole packages, and of some packages only some modules."""

    packages: frozenset[str] = frozenset()
    only: Mapping[str, tuple[str, ...]] | None = None  # package → the module paths allowed in it (and below)
    anything: bool = False


CONTRACT: dict[str, Rule] = {
    TOP_LEVEL: Rule(frozenset({"api", "data", "estimators"}),
                    only={"data": ("data.loaders",), "estimators": ("estimators.protocol",)}),
    "config": Rule(),
    "models": Rule(),
    "utils": Rule(),
    "store": Rule(frozenset({"config", "utils"})),
    "scenes": Rule(frozenset({"config", "utils"})),
    "generate": Rule(frozenset({"config", "scenes", "store", "utils"})),
    "data": Rule(frozenset({"config", "store"})),
    "training": Rule(frozenset({"models", "data", "store", "config", "utils"})),
    "estimators": Rule(frozenset({"models", "data", "store", "training", "config", "utils"})),
    "eval": Rule(frozenset({"estimators", "data", "store", "config", "utils", "viz", "scenes", "generate"}),
                 only={"generate": ("generate.render", "generate.camera")}),
    "viz": Rule(frozenset({"scenes"})),
    "cli": Rule(anything=True),
    "api": Rule(anything=True),
}


@dataclass(frozen=True)
class Import:
    """One import of the top package found in a source file."""

    file: Path  # relative to the folder holding the top package
    line: int
    importer: str  # dotted module name, e.g. "synthcal.eval.metrics"
    target: str  # dotted module imported, e.g. "synthcal.generate.render"

    def __str__(self) -> str:
        return f"{self.file}:{self.line}: {self.importer} imports {self.target}"


def module_name(path: Path, root: Path) -> str:
    """``root/synthcal/eval/metrics.py`` → ``synthcal.eval.metrics``; a package's ``__init__.py`` → the package."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def is_module(name: str, root: Path) -> bool:
    """Whether the dotted ``name`` is a module or package in the tree under ``root``."""
    path = root.joinpath(*name.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def imports_in(path: Path, root: Path, top: str) -> Iterator[Import]:
    """Every import of ``top`` or its modules in one source file, at any depth of its syntax tree.

    ``from PACKAGE import NAME`` counts as an import of ``PACKAGE.NAME`` when that is a
    module, else of ``PACKAGE`` (whose ``__init__`` runs either way).
    """
    importer = module_name(path, root)
    package = importer if path.name == "__init__.py" else importer.rpartition(".")[0]
    relative = path.relative_to(root)
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            targets = [f"{base}.{alias.name}" if is_module(f"{base}.{alias.name}", root) else base
                       for alias in node.names]
        else:
            continue
        for target in targets:
            if target == top or target.startswith(top + "."):
                yield Import(relative, node.lineno, importer, target)


def all_imports(root: Path, top: str) -> list[Import]:
    """The imports of ``top`` in every module of the package ``root/top``, sorted by file and line."""
    found = [imp for path in sorted((root / top).rglob("*.py")) for imp in imports_in(path, root, top)]
    return sorted(found, key=lambda imp: (str(imp.file), imp.line, imp.target))


def package_of(module: str) -> str:
    """``synthcal.eval.metrics`` → ``eval``; ``synthcal.config`` → ``config``; ``synthcal`` → ``""``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else TOP_LEVEL


def violations(imports: list[Import], contract: Mapping[str, Rule]) -> list[str]:
    """One line per import that breaks ``contract``: file, line, what it imports and why it may not."""
    found = []
    for imp in imports:
        source, target = package_of(imp.importer), package_of(imp.target)
        rule = contract.get(source)
        if rule is None:
            found.append(f"{imp}: package {source!r} is not in the contract")
            continue
        if rule.anything:
            continue
        if source != TOP_LEVEL and target in (source, TOP_LEVEL):  # its own modules
            continue
        if target not in rule.packages:
            allowed = ", ".join(sorted(rule.packages)) or "nothing of synthcal"
            who = source if source != TOP_LEVEL else f"{imp.importer}/__init__.py"
            found.append(f"{imp}: {who} may import {allowed}")
            continue
        modules = (rule.only or {}).get(target)
        inside = imp.target.split(".", 1)[1]
        if modules is not None and not any(inside == m or inside.startswith(m + ".") for m in modules):
            found.append(f"{imp}: {source} may import of {target} only {', '.join(modules)}")
    return found


def package_graph(imports: list[Import]) -> dict[str, dict[str, Import]]:
    """Package → package it imports → the first import that does it (self-imports and the top level left out)."""
    graph: dict[str, dict[str, Import]] = {}
    for imp in imports:
        source, target = package_of(imp.importer), package_of(imp.target)
        if source != target and TOP_LEVEL not in (source, target):
            graph.setdefault(source, {}).setdefault(target, imp)
    return graph


def package_cycles(imports: list[Import]) -> list[list[str]]:
    """The import cycles between packages: each strongly connected group of two or more, sorted."""
    graph = package_graph(imports)
    nodes = sorted(set(graph) | {t for targets in graph.values() for t in targets})
    reach = {n: set(graph.get(n, {})) for n in nodes}
    changed = True
    while changed:  # transitive closure: a dozen packages, no need for Tarjan
        changed = False
        for n in nodes:
            more = set().union(*(reach[m] for m in reach[n])) - reach[n] if reach[n] else set()
            if more:
                reach[n] |= more
                changed = True
    groups = {frozenset([n] + [m for m in nodes if m != n and m in reach[n] and n in reach[m]]) for n in nodes}
    return sorted(sorted(g) for g in groups if len(g) > 1)


def describe_cycles(imports: list[Import]) -> list[str]:
    """Each cycle with one import per edge inside it."""
    graph = package_graph(imports)
    lines = []
    for group in package_cycles(imports):
        lines.append(" ↔ ".join(group))
        lines += [f"    {graph[a][b]}" for a in group for b in group if b in graph.get(a, {})]
    return lines


# --- the real tree ------------------------------------------------------------------------------


def test_imports_follow_the_contract():
    imports = all_imports(ROOT, TOP)
    assert len(imports) > 50, "the parser found suspiciously few imports of synthcal"
    packages = {package_of(imp.importer) for imp in imports} | {package_of(imp.target) for imp in imports}
    assert {"config", "store", "generate", "data", "training", "estimators", "eval", "cli"} <= packages
    found = violations(imports, CONTRACT)
    assert not found, "imports that break the architecture (tests/test_architecture.py):\n" + "\n".join(found)


def test_no_import_cycle_between_packages():
    imports = all_imports(ROOT, TOP)
    assert not package_cycles(imports), "import cycles between packages:\n" + "\n".join(describe_cycles(imports))


def test_the_contract_itself_has_no_cycle():
    # Imports of every allowed pair: the contract must not permit a cycle either.
    allowed = [Import(Path("contract"), 0, f"{TOP}.{source}", f"{TOP}.{target}")
               for source, rule in CONTRACT.items() if source != TOP_LEVEL and not rule.anything
               for target in rule.packages]
    assert not package_cycles(allowed)


# --- the checker on a fake package ----------------------------------------------------------------


def write_tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


FAKE = {
    "fake/__init__.py": "",
    "fake/config.py": "import os\n\nimport yaml\n\n\ndef late():\n    from .generate.grid import g\n",
    "fake/store/__init__.py": "from . import format\nfrom .format import open_store\n",
    "fake/store/format.py": "from fake.config import C\nimport fake.utils\n",
    "fake/utils.py": "",
    "fake/generate/__init__.py": "",
    "fake/generate/grid.py": "from fake.config import C\n",
    "fake/generate/render.py": "",
    "fake/generate/pipeline.py": "from fake.store import open_store\n",
    "fake/scenes/__init__.py": "from .soccer import pitch\n",
    "fake/scenes/soccer.py": "from ..generate import grid\n",
    "fake/models/__init__.py": "import torch\n\n\ndef f():\n    if True:\n        from fake.store import format\n",
    "fake/eval/__init__.py": "",
    "fake/eval/metrics.py": ("from ..generate.render import r\nfrom ..scenes.soccer import s\n"
                             "from ..generate import pipeline\nfrom fake.generate import camera_helper\n"),
    "fake/viz.py": "from fake.scenes import colorize\n",
    "fake/cli.py": "from fake.generate.pipeline import generate\nfrom fake.eval import metrics\n",
    "fake/plugins/__init__.py": "",
}


def test_checker_reports_forbidden_imports_with_file_and_line(tmp_path):
    write_tree(tmp_path, FAKE)
    imports = all_imports(tmp_path, "fake")
    found = violations(imports, CONTRACT)
    expected = [
        "fake/config.py:7: fake.config imports fake.generate.grid",  # function level, relative
        "fake/eval/metrics.py:3: fake.eval.metrics imports fake.generate.pipeline",  # from .. import module
        "fake/eval/metrics.py:4: fake.eval.metrics imports fake.generate",  # a name of generate/__init__
        "fake/models/__init__.py:6: fake.models imports fake.store.format",  # nested in a function and an if
        "fake/scenes/soccer.py:1: fake.scenes.soccer imports fake.generate.grid",  # scenes sit below generate
    ]
    assert [line.rsplit(": ", 1)[0] for line in found] == expected, "\n".join(found)
    assert "only generate.render, generate.camera" in found[1]
    assert "models may import nothing of synthcal" in found[3]
    assert "scenes may import config, utils" in found[4]


def test_checker_parses_relative_and_function_level_imports(tmp_path):
    write_tree(tmp_path, FAKE)
    targets = {(imp.importer, imp.target) for imp in all_imports(tmp_path, "fake")}
    assert ("fake.store", "fake.store.format") in targets  # from . import format
    assert ("fake.scenes", "fake.scenes.soccer") in targets  # from .soccer import pitch
    assert ("fake.eval.metrics", "fake.scenes.soccer") in targets  # from ..scenes.soccer import s
    assert ("fake.scenes.soccer", "fake.generate.grid") in targets  # from ..generate import grid
    assert ("fake.store.format", "fake.utils") in targets  # import fake.utils
    assert not any(t.startswith(("os", "torch")) for _, t in targets)


def test_checker_reports_cycles_and_unknown_packages(tmp_path):
    write_tree(tmp_path, FAKE)
    imports = all_imports(tmp_path, "fake")
    assert package_cycles(imports) == [["config", "generate", "store"]]  # config → generate → store → config
    assert any("fake/config.py:7" in line for line in describe_cycles(imports))
    write_tree(tmp_path, {"fake/plugins/__init__.py": "from fake import config\n"})
    found = violations(all_imports(tmp_path, "fake"), CONTRACT)
    assert any(line.startswith("fake/plugins/__init__.py:1: fake.plugins imports fake.config: package 'plugins'")
               for line in found), found


# --- private names stay in their module -----------------------------------------------------------


def is_private(name: str) -> bool:
    """``_x`` is private; ``__x__`` (a dunder) and ``__x`` at module level are not this test's business."""
    return name.startswith("_") and not name.startswith("__")


def dotted(node: ast.expr) -> str | None:
    """``a.b.c`` → ``"a.b.c"``; anything but a chain of names and attributes → None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([node.id, *reversed(parts)])


@dataclass
class Scope:
    """What a source file's names mean: its module, its package, and the local names bound to ``top`` modules."""

    root: Path
    top: str
    own: str | None  # the file's module, whose private names it may use (None: a test, or a program string)
    package: str  # for relative imports
    modules: dict[str, str]  # local name → the module it is bound to

    def base_of(self, node: ast.ImportFrom) -> str:
        """The module a ``from … import`` reads from, relative imports resolved."""
        if not node.level:
            return node.module or ""
        parts = self.package.split(".")
        return ".".join(parts[:len(parts) - node.level + 1] + ([node.module] if node.module else []))

    def module_named(self, chain: str) -> str | None:
        """The module that the dotted ``chain`` of local names and attributes names, else None."""
        head, *rest = chain.split(".")
        module = self.modules.get(head)
        for part in rest:
            if module is None or not is_module(f"{module}.{part}", self.root):
                return None
            module = f"{module}.{part}"
        return module

    def private_of(self, module: str | None, name: str) -> str | None:
        """``module.name`` when it is another ``top`` module's private name, else None."""
        if module and (module == self.top or module.startswith(self.top + ".")) and module != self.own \
                and is_private(name):
            return f"{module}.{name}"
        return None


def scope_of(tree: ast.Module, path: Path, root: Path, top: str, program: bool) -> Scope:
    """The :class:`Scope` of one parsed file (or of a program string in it, ``program=True``)."""
    own = module_name(path, root) if path.is_relative_to(root / top) else None
    package = (own if path.name == "__init__.py" else own.rpartition(".")[0]) if own else ""
    scope = Scope(root, top, None if program else own, package, {top: top})
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            scope.modules.update({alias.asname: alias.name for alias in node.names  # plain ``import top.m`` binds top
                                  if alias.asname and alias.name.startswith(top + ".")})
        elif isinstance(node, ast.ImportFrom):
            base = scope.base_of(node)
            scope.modules.update({alias.asname or alias.name: f"{base}.{alias.name}" for alias in node.names
                                  if is_module(f"{base}.{alias.name}", root)})
    return scope


def private_use(node: ast.AST, scope: Scope) -> str | None:
    """The private name one attribute, ``setattr``-like call or dotted-path string reaches for, else None."""
    if isinstance(node, ast.Attribute) and (chain := dotted(node.value)):
        return scope.private_of(scope.module_named(chain), node.attr)
    if (isinstance(node, ast.Call) and len(node.args) >= 2
            and (dotted(node.func) or "").rpartition(".")[2] in ("setattr", "getattr", "delattr")
            and (chain := dotted(node.args[0])) and isinstance(name := node.args[1], ast.Constant)
            and isinstance(name.value, str)):
        return scope.private_of(scope.module_named(chain), name.value)
    if isinstance(node, ast.Constant) and isinstance(node.value, str) and re.fullmatch(r"[\w.]+", node.value):
        chain, _, attr = node.value.rpartition(".")  # as monkeypatch.setattr("top.m._x", …) takes
        return scope.private_of(scope.module_named(chain), attr) if chain else None
    return None


def program_in(node: ast.AST, top: str) -> str | None:
    """The text of a string constant that mentions ``top`` and parses as Python (a ``python -c`` program)."""
    if not (isinstance(node, ast.Constant) and isinstance(node.value, str) and top in node.value):
        return None
    try:
        ast.parse(node.value)
    except SyntaxError:
        return None  # prose
    return node.value


def private_uses_in(source: str, path: Path, root: Path, top: str, line_offset: int = 0,
                    program: bool = False) -> Iterator[str]:
    """Every private name of another ``top`` module that ``source`` imports or reaches for: ``file:line: …``.

    Counted: ``from M import _x``; ``M._x`` through a name bound to module ``M`` (by
    ``import … as``, ``from P import M``, or the top package's name); ``setattr``/
    ``getattr``/``delattr`` (``monkeypatch``'s too) of a ``"_x"`` on a module;
    ``"top.M._x"`` dotted-path strings; and code inside string constants (a
    ``python -c`` program, ``program=True``: it runs as ``__main__``, so even its own
    file's private names are another module's). A module's own private names, and
    private members of classes, are left alone.
    """
    tree = ast.parse(source, str(path))
    scope = scope_of(tree, path, root, top, program)
    relative = path.relative_to(root)
    for node in ast.walk(tree):
        line = line_offset + getattr(node, "lineno", 0)
        if isinstance(node, ast.ImportFrom):
            base = scope.base_of(node)
            yield from (f"{relative}:{line}: imports {found}" for alias in node.names
                        if (found := scope.private_of(base, alias.name)))
        elif found := private_use(node, scope):
            yield f"{relative}:{line}: uses {found}"
        elif (text := program_in(node, top)) is not None:
            yield from private_uses_in(text, path, root, top, line - 1, program=True)


def private_uses(root: Path, top: str, folders: tuple[str, ...]) -> list[str]:
    """:func:`private_uses_in` over every ``.py`` file under ``folders`` of ``root``, sorted, without repeats."""
    found = {use for folder in folders for path in sorted((root / folder).rglob("*.py"))
             for use in private_uses_in(path.read_text(), path, root, top)}
    return sorted(found, key=lambda use: (use.split(":")[0], int(use.split(":")[1]), use))


# Left for the scenes move of issue 21, which owns osm.py (the lead makes them public at the merge):
# file → the private names it may still use.
def test_no_private_name_crosses_a_module():
    found = list(private_uses(ROOT, TOP, (TOP, "tests", "benchmarks")))
    assert not found, ("private names of synthcal used outside their module (make them public and documented, "
                       "or move them to where they are used):\n" + "\n".join(found))


def test_private_checker_finds_imports_attributes_monkeypatches_and_code_strings(tmp_path):
    write_tree(tmp_path, {
        "fake/__init__.py": "",
        "fake/eval/__init__.py": "",
        "fake/eval/runs.py": "def _parameters(): ...\n\n\ndef public(): return _parameters()\n",
        "fake/eval/isolation.py": ("from .runs import _parameters, public\nfrom fake.eval import runs\n\n\n"
                                   "def f():\n    return runs._helper(), runs.public()\n"
                                   "CODE = 'from fake.eval.isolation import _child; _child()'\n"
                                   "OWN = 'from fake.eval.runs import public'\n"),
        "tests/test_x.py": ("import fake.eval.runs as r\nimport fake.eval.isolation\n\n\n"
                            "def test(monkeypatch):\n    monkeypatch.setattr(r, '_p', 1)\n"
                            "    monkeypatch.setattr('fake.eval.runs._q', 2)\n"
                            "    fake.eval.isolation._z()\n    r.Runner()._method()\n    getattr(r, 'public')\n"),
    })
    found = private_uses(tmp_path, "fake", ("fake", "tests"))
    assert found == [
        "fake/eval/isolation.py:1: imports fake.eval.runs._parameters",
        "fake/eval/isolation.py:6: uses fake.eval.runs._helper",
        "fake/eval/isolation.py:7: imports fake.eval.isolation._child",  # its own, but the program runs as __main__
        "tests/test_x.py:6: uses fake.eval.runs._p",
        "tests/test_x.py:7: uses fake.eval.runs._q",
        "tests/test_x.py:8: uses fake.eval.isolation._z",
    ], "\n".join(found)
