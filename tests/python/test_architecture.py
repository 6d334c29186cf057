"""The house rules of the package, checked on its source (docs/ARCHITECTURE.md).

- imports point one way: cli -> report -> plots -> fit/studies -> compare -> campaigns ->
  signals -> model -> (data, the core); type-only imports and the module ``__getattr__`` that
  keeps a vadsim 0.1 name working are the only exceptions;
- no private name (leading underscore) is imported from another module;
- no function is longer than ``MAX_LINES`` except the listed ones, each with its reason;
- every old import path (``vadsim.sweep``, ``vadsim.presets``...) still reads the module that
  now holds it, with a DeprecationWarning naming the new path, and ``vadsim.simulate`` stays
  the function; no old path is used inside the repository;
- every module is reached by its path: no package exports a name that hides a module;
- no module is longer than ``MAX_MODULE_LINES``;
- no ``vadsim.fit`` module imports ``vadsim.report`` or ``vadsim.plots`` (results are data; their
  words and figures live above them).
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import re
from pathlib import Path
from types import ModuleType

import pytest
import vadsim
from vadsim._aliases import ALIASES, MOVED_OUT

PACKAGE = Path(vadsim.__file__).resolve().parent

LAYERS = {
    "vadsim._version": 0, "vadsim._checks": 0, "vadsim._aliases": 0, "vadsim._html": 0,
    "vadsim._executors": 0, "vadsim._progress": 0, "vadsim._interrupt": 0, "vadsim._render": 0,
    "vadsim.data": 0,
    "vadsim._core": 0, "vadsim.model": 1, "vadsim.signals": 2, "vadsim.campaigns": 3,
    "vadsim.compare": 4, "vadsim.fit": 5, "vadsim.studies": 5, "vadsim.plots": 6,
    "vadsim.report": 7, "vadsim.blind": 7, "vadsim.cli": 8, "vadsim.__main__": 9,
}
"""The layer of each top-level part: a module may import its own layer and those below."""

MAX_LINES = 80

MAX_MODULE_LINES = 600
"""Lines of one module at most: a newcomer reads one module whole."""

REPOSITORY = Path(__file__).resolve().parents[2]

LONG_FUNCTIONS: dict[str, str] = {
    # module:function -> why it is long
}
"""Functions allowed over MAX_LINES, each with the reason."""


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if "data" in parts[1:2] and parts[-1] != "data":  # scripts that regenerate data
            continue
        out.append((".".join(parts), path))
    return out


def _layer(module: str) -> int | None:
    for prefix in sorted(LAYERS, key=len, reverse=True):
        if module == prefix or module.startswith(prefix + "."):
            return LAYERS[prefix]
    return None


def _imports(tree: ast.Module, module: str, is_package: bool):
    """(imported module, names, line) of every runtime import outside a module __getattr__."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for n in ast.walk(node))
        if isinstance(node, ast.FunctionDef) and node.name == "__getattr__":
            skip.update(id(n) for n in ast.walk(node))
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, [], node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = module.split(".") if is_package else module.split(".")[:-1]
                pkg = pkg[: len(pkg) - node.level + 1]
                base = ".".join(pkg + ([base] if base else []))
            yield base, [a.name for a in node.names], node.lineno


def test_imports_point_one_way() -> None:
    bad = []
    for module, path in _modules():
        mine = _layer(module)
        if mine is None or module == "vadsim":
            continue
        tree = ast.parse(path.read_text())
        for target, names, line in _imports(tree, module, path.name == "__init__.py"):
            targets = [target] + [f"{target}.{n}" for n in names]
            for t in targets:
                theirs = _layer(t) if t.startswith("vadsim") else None
                if theirs is not None and theirs > mine:
                    bad.append(f"{module}:{line} imports {t} (layer {theirs} > {mine})")
                    break
    assert not bad, "\n".join(bad)


def test_no_private_names_across_modules() -> None:
    bad = []
    for module, path in _modules():
        tree = ast.parse(path.read_text())
        for target, names, line in _imports(tree, module, path.name == "__init__.py"):
            if not target.startswith("vadsim"):
                continue
            private = [n for n in names if n.startswith("_") and n != "__version__"
                       and not (target == "vadsim" and n in ("_core", "_aliases"))]
            if private:
                bad.append(f"{module}:{line} imports {private} from {target}")
    assert not bad, "\n".join(bad)


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines of a function without its docstring (a numpydoc docstring is not code)."""
    body = node.body
    first = body[0]
    if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
            and isinstance(first.value.value, str)):
        doc = first.end_lineno - first.lineno + 1
        return node.end_lineno - node.lineno + 1 - doc
    return node.end_lineno - node.lineno + 1


def test_no_monolith_functions() -> None:
    long = {}
    for module, path in _modules():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = _code_lines(node)
                if n > MAX_LINES:
                    long[f"{module}:{node.name}"] = n
    unexplained = {k: v for k, v in long.items() if k not in LONG_FUNCTIONS}
    assert not unexplained, f"functions over {MAX_LINES} lines: {unexplained}"


@pytest.mark.parametrize("old", sorted(ALIASES))
def test_old_import_paths_read_the_new_modules_with_a_warning(old: str) -> None:
    new = importlib.import_module(ALIASES[old])
    module = importlib.import_module(old)
    name = next(n for n in getattr(new, "__all__", dir(new)) if not n.startswith("_"))
    with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated.*import {ALIASES[old]}"):
        got = getattr(module, name)
    assert got is getattr(new, name)
    assert callable(vadsim.simulate), "importing an old path must not replace vadsim.simulate"
    package, _, leaf = old.rpartition(".")
    if leaf in getattr(importlib.import_module(package), "__all__", ()):
        # renamed because its package exports a function of that name, which stays
        assert not isinstance(getattr(importlib.import_module(package), leaf), ModuleType), \
            f"importing {old} replaced {package}.{leaf}"


def test_every_module_is_reached_by_its_path() -> None:
    """``vadsim.a.b`` read as an attribute is the module ``vadsim.a.b``: no package exports a
    name that hides one of its modules (``vadsim.model.simulate`` was the function, and
    ``import vadsim.model.simulate as m`` gave it)."""
    hidden = {}
    for info in pkgutil.walk_packages([str(PACKAGE)], "vadsim."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        parent, _, leaf = info.name.rpartition(".")
        got = getattr(importlib.import_module(parent), leaf, None)
        if got is not module:
            hidden[info.name] = type(got).__name__
    assert not hidden, hidden


@pytest.mark.parametrize("old", sorted(MOVED_OUT))
def test_old_paths_reach_the_names_split_out_of_their_module(old: str) -> None:
    """A 0.1 script reads every public name of the old module, wherever 0.2 put it."""
    module = importlib.import_module(old)
    for moved in MOVED_OUT[old]:
        target = importlib.import_module(moved)
        for name in getattr(target, "__all__", []):
            with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated"):
                assert getattr(module, name) is getattr(target, name)


@pytest.mark.parametrize("short", sorted(o.split(".", 1)[1] for o in ALIASES
                                         if o.count(".") == 1 and o != "vadsim.simulate"))
def test_the_facade_short_names_warn_and_give_the_new_modules(short: str) -> None:
    with pytest.warns(DeprecationWarning, match=f"vadsim.{short} is deprecated"):
        got = getattr(vadsim, short)
    assert got is importlib.import_module(ALIASES[f"vadsim.{short}"])


_OLD_IMPORT = re.compile(
    r"(?:^|\n)\s*(?:from\s+(?P<a>vadsim(?:\.\w+)+)\s+import"
    r"|import\s+(?P<b>vadsim(?:\.\w+)+)"
    r"|from\s+vadsim\s+import\s+(?P<c>[\w ,()]+))")


def _old_paths_in(text: str) -> list[str]:
    found = []
    for m in _OLD_IMPORT.finditer(text):
        if m.group("a") or m.group("b"):
            path = m.group("a") or m.group("b")
            if any(path == o or path.startswith(o + ".") for o in ALIASES):
                found.append(path)
        else:
            names = [n.strip().split(" as ")[0] for n in m.group("c").strip("() ").split(",")]
            found += [f"vadsim.{n}" for n in names
                      if f"vadsim.{n}" in ALIASES and n != "simulate"]
    return found


def test_no_old_import_path_is_used_inside_the_repository() -> None:
    """Code, docs and examples import each module by its one path (the aliases are for users'
    old scripts, for one release)."""
    places = [*REPOSITORY.joinpath("python").rglob("*.py"),
              *REPOSITORY.joinpath("tests").rglob("*.py"),
              *REPOSITORY.joinpath("bench").rglob("*.py"),
              *REPOSITORY.joinpath("examples").rglob("*.py"),
              *REPOSITORY.joinpath("docs").rglob("*.md"),
              *REPOSITORY.joinpath("docs").rglob("*.rst"), REPOSITORY / "README.md"]
    bad = {}
    for path in places:
        if path.name in ("_aliases.py", "test_architecture.py") or "_build" in path.parts:
            continue
        old = _old_paths_in(path.read_text(errors="replace"))
        if old:
            bad[str(path.relative_to(REPOSITORY))] = old
    assert not bad, bad


def test_no_monolith_modules() -> None:
    long = {module: n for module, path in _modules()
            if (n := len(path.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_fit_does_not_import_report_or_plots() -> None:
    """Results are data: their text, HTML and figures live above ``fit`` (and a circle through
    report or plots back to fit cannot form). Type-only imports count too."""
    bad = []
    for module, path in _modules():
        if not module.startswith("vadsim.fit"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            targets = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                       [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            bad += [f"{module}:{node.lineno} imports {t}" for t in targets
                    if t.startswith(("vadsim.report", "vadsim.plots"))]
    assert not bad, bad


def test_one_residual_definition() -> None:
    """Validation, calibration and diagnosis standardise through vadsim.compare only (its
    module ``residuals``)."""
    for module, path in _modules():
        if module == "vadsim.compare.residuals":
            continue
        text = path.read_text()
        assert "def event_residuals" not in text and "def standardised_residual" not in text, (
            f"{module} defines a residual of its own")


MAX_PARAMETERS = 8
"""Parameters of a public function at most, unless its docstring says why it needs more."""


def test_long_signatures_say_why() -> None:
    """A public function with more than ``MAX_PARAMETERS`` parameters says in its docstring
    why ("Why so many parameters: ..."), so that a long signature is a decision, not drift."""
    silent = []
    for module, path in _modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.FunctionDef) or node.name.startswith("_"):
                continue
            a = node.args
            names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
            n = len(names) - (names[:1] in (["self"], ["cls"]))
            doc = (ast.get_docstring(node) or "").lower()
            if n > MAX_PARAMETERS and "why so many parameters" not in doc:
                silent.append(f"{module}:{node.name} ({n})")
    assert not silent, f"over {MAX_PARAMETERS} parameters without a reason: {silent}"
