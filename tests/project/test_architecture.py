"""The package's shape, checked on its source (docs/architecture.md).

The stages are packages in pipeline order; a module may import from its own
package and from packages below it, never from one above. No import cycles,
at module level or inside functions, and no ``_private`` name crosses a
package boundary. No module over 600 lines, no function over 120, none taking more than 15
parameters (options travel in records: ``RunOptions``, ``ViewFiles``, ``BatchOptions``).
"""

from __future__ import annotations

import ast
import pathlib

import pytest

import raycast_shade

PKG = pathlib.Path(raycast_shade.__file__).parent

# Lowest first. Root modules other than __init__ / __main__ (render.py) sit between insight and apps.
LAYERS = ("common", "scene", "visibility", "shading", "output", "study", "insight", "<root>", "apps", "<top>")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 120
MAX_PARAMETERS = 15  # positional and keyword-only; *args and **kwargs not counted


def _modules():
    out = {}
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG).with_suffix("")
        parts = ("raycast_shade",) + rel.parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _is_package(name):
    return (PKG.joinpath(*name.split(".")[1:]) / "__init__.py").exists() if name != "raycast_shade" else True


def layer(name: str) -> str:
    parts = name.split(".")
    if len(parts) == 1 or parts[1] == "__main__":
        return "<top>"
    if len(parts) == 2 and not _is_package(name):
        return "<root>"
    return parts[1]


def package(name: str) -> str:
    """The stage package a module belongs to (or its layer name at the root)."""
    return layer(name)


def imports(name: str, path: pathlib.Path):
    """(line, target module, imported names) for every import of the package, anywhere in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_pkg = path.name == "__init__.py"
    here = name.split(".") if is_pkg else name.split(".")[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "raycast_shade":
                    yield node.lineno, alias.name, ()
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "raycast_shade":
                continue
            names = tuple(a.name for a in node.names)
            submodules = [f"{mod}.{n}" for n in names if f"{mod}.{n}" in MODULES]
            plain = tuple(n for n in names if f"{mod}.{n}" not in MODULES)
            for sub in submodules:
                yield node.lineno, sub, ()
            if plain or not submodules:
                yield node.lineno, mod, plain


def _graph():
    edges = {}
    for name, path in MODULES.items():
        edges[name] = {(t, line, names) for line, t, names in imports(name, path) if t != name}
    return edges


GRAPH = _graph()


def test_every_import_resolves_to_a_module():
    bad = [f"{m}:{line} imports {t}" for m, es in GRAPH.items() for t, line, _ in es if t not in MODULES]
    assert not bad, "\n".join(bad)


def test_no_package_imports_one_above_it():
    bad = []
    for m, es in GRAPH.items():
        for t, line, _ in es:
            if t in MODULES and LAYERS.index(layer(t)) > LAYERS.index(layer(m)):
                bad.append(f"{MODULES[m].relative_to(PKG)}:{line} ({layer(m)}) imports {t} ({layer(t)})")
    assert not bad, "\n".join(bad)


def test_no_private_name_crosses_a_package():
    bad = []
    for m, es in GRAPH.items():
        for t, line, names in es:
            if t not in MODULES or package(t) == package(m):
                continue
            private_path = [p for p in t.split(".")[1:] if p.startswith("_") and not p.startswith("__")]
            private_names = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if private_path or private_names:
                bad.append(f"{MODULES[m].relative_to(PKG)}:{line} imports {private_names or private_path} from {t}")
    assert not bad, "\n".join(bad)


def test_no_import_cycles():
    # Tarjan's strongly connected components over module-level and function-level imports alike.
    index, low, stack, on, sccs = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w, _, _ in GRAPH.get(v, ()):
            if w not in MODULES:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                sccs.append(sorted(comp))

    for v in MODULES:
        if v not in index:
            visit(v)
    assert not sccs, f"import cycles: {sccs}"


def test_the_rules_catch_what_they_forbid():
    """The checks above are not vacuous: the graph they read has the pipeline's edges."""
    assert ("raycast_shade.visibility.hits", ) and any(
        t == "raycast_shade.visibility.hits" for t, _, _ in GRAPH["raycast_shade.render"] | GRAPH[
            "raycast_shade.visibility.cast"])
    assert LAYERS.index(layer("raycast_shade.apps.cli")) > LAYERS.index(layer("raycast_shade.render"))
    assert layer("raycast_shade.render") == "<root>" and layer("raycast_shade") == "<top>"
    for pkg in LAYERS:
        if not pkg.startswith("<"):
            assert (PKG / pkg / "__init__.py").exists(), pkg


@pytest.mark.parametrize("name", sorted(MODULES))
def test_module_and_function_sizes(name):
    path = MODULES[name]
    src = path.read_text(encoding="utf-8")
    lines = src.count("\n")
    assert lines <= MAX_MODULE_LINES, f"{path.relative_to(PKG)}: {lines} lines"
    long = []
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            n = node.end_lineno - node.lineno + 1
            if n > MAX_FUNCTION_LINES:
                long.append(f"{node.name}() at line {node.lineno}: {n} lines")
    assert not long, f"{path.relative_to(PKG)}: " + "; ".join(long)


def parameter_counts(src: str) -> list:
    """``(name, line, count)`` of every function and lambda in ``src``, nested ones included: its
    positional-only, positional and keyword-only parameters (``*args`` and ``**kwargs`` not counted)."""
    out = []
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            out.append((getattr(node, "name", "<lambda>"), node.lineno,
                        len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)))
    return out


def test_no_function_takes_more_than_15_parameters():
    """Long signatures grow one flag at a time; the front ends' options live in records instead
    (issue 40: ``render_views`` had 21, ``iter_batch`` 19)."""
    wide = [f"{path.relative_to(PKG)}:{line} {name}() takes {n}"
            for path in sorted(PKG.rglob("*.py"))
            for name, line, n in parameter_counts(path.read_text(encoding="utf-8")) if n > MAX_PARAMETERS]
    assert not wide, f"over {MAX_PARAMETERS} parameters (pass a record instead): " + "; ".join(wide)
    # the count itself: every kind of parameter but *args and **kwargs, in methods, nested functions and lambdas
    assert parameter_counts("def f(a, /, b, *c, d, **e):\n    g = lambda x, y=1: x\n") == \
        [("f", 1, 3), ("<lambda>", 2, 2)]
    assert parameter_counts("class C:\n    def m(self, *, k):\n        pass\n") == [("m", 2, 2)]


_ENDS = (ast.Return, ast.Raise, ast.Continue, ast.Break)


def unreachable(src: str) -> list:
    """Lines of statements that follow a ``return``, ``raise``, ``continue`` or ``break`` in the same
    block: code that never runs (left behind when a body was replaced by a call)."""
    out = []
    for node in ast.walk(ast.parse(src)):
        for field in ("body", "orelse", "finalbody"):
            block = getattr(node, field, None)
            if not isinstance(block, list):
                continue
            for a, b in zip(block, block[1:]):
                if isinstance(a, _ENDS):
                    out.append(b.lineno)
    return out


def test_no_unreachable_statements():
    """Package, benchmarks, docs generators and tests: no statement after a block's last exit."""
    root = PKG.parent
    found = []
    for folder in ("raycast_shade", "benchmarks", "docs", "tests"):
        for path in sorted((root / folder).rglob("*.py")):
            found += [f"{path.relative_to(root)}:{line}" for line in unreachable(path.read_text(encoding="utf-8"))]
    assert not found, "unreachable: " + ", ".join(found)
    assert unreachable("def f():\n    return 1\n    x = 2\n") == [3]  # the check itself finds one
    assert unreachable("for i in x:\n    if i:\n        continue\n    y = i\n") == []
