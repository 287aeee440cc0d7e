"""No ``obj.__dict__`` access in the library outside pickling hooks (issue 21, item 4).

A frozen dataclass that memoises (``Scene.geometry``) keeps the memo in a private attribute
written once with ``object.__setattr__`` under a lock; reaching into ``__dict__`` instead
bypasses properties (an entry named like a property is never read) and ties callers to the
storage. The walk reads the source with ``ast``; ``PENDING`` names the places other work
removes, each with its reason, and may only shrink.
"""

from __future__ import annotations

import ast
import pathlib

import raycast_shade

PKG = pathlib.Path(raycast_shade.__file__).parent
HOOKS = {"__getstate__", "__setstate__", "__reduce__", "__reduce_ex__", "__copy__", "__deepcopy__"}
PENDING: dict = {}  # (file, function) -> why it still reaches into a __dict__: none left


def dict_accesses(source: str) -> set[str]:
    """Names of the functions of ``source`` that touch some ``__dict__`` (``"<module>"`` at
    module level), pickling hooks left out."""
    found = set()

    def walk(node, where):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if child.name not in HOOKS:
                    walk(child, child.name)
            elif isinstance(child, ast.Attribute) and child.attr == "__dict__":
                found.add(where)
                walk(child, where)
            else:
                walk(child, where)

    walk(ast.parse(source), "<module>")
    return found


def _found():
    return {(str(p.relative_to(PKG)), name) for p in sorted(PKG.rglob("*.py"))
            for name in dict_accesses(p.read_text(encoding="utf-8"))}


def test_no_dict_access_outside_pickling_hooks():
    new = _found() - set(PENDING)
    assert not new, f"__dict__ reached into (use a private attribute, or a pickling hook): {sorted(new)}"


def test_the_scene_keeps_its_geometry_without_dict_access():
    assert not {(path, name) for path, name in _found() if path.startswith(("scene/", "apps/", "render.py"))}


def test_the_walk_sees_dict_access_but_not_in_hooks():
    src = (
        "class A:\n"
        "    def __getstate__(self):\n        return dict(self.__dict__)\n"
        "    def memo(self):\n        return self.__dict__.get('x')\n"
        "def f(o):\n    o.__dict__['y'] = 1\n"
        "Z = vars\n"
    )
    assert dict_accesses(src) == {"memo", "f"}
    assert dict_accesses("def g(o):\n    return o.x\n") == set()
