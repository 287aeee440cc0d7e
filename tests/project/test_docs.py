"""Docs that cannot drift: the API reference (``docs/api``) is built from the docstrings
and current, and no reference names nothing (``python -m docs.api --check``)."""

from __future__ import annotations

import os

import pytest

api = pytest.importorskip("docs.api.__main__")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Dangling references in files another helper rewrites in this issue (issue 21, items 1-5:
# render.py, visibility/, common/layout.py); each entry is (file, reference). Remove them as they go.
KNOWN = {
    ("raycast_shade/render.py", "raycast_shade.auto"),
    ("raycast_shade/render.py", "raycast_shade.raster"),
    ("raycast_shade/render.py", "raycast_shade.interpolation"),
    ("raycast_shade/common/layout.py", "tests/test_layout.py"),
    ("raycast_shade/visibility/interpolation.py", "raycast_shade.raster.rasterize"),
    ("raycast_shade/visibility/interpolation.py", "raycast_shade.hits.HitBuffer"),
    ("raycast_shade/visibility/raster.py", "raycast_shade.hits.HitBuffer"),
    ("raycast_shade/visibility/raster.py", "raycast_shade.rays.pixel_ray"),
    ("raycast_shade/visibility/raster.py", "raycast_shade.scene.Scene"),
}


def test_the_api_reference_is_built_from_the_current_docstrings():
    assert api.stale() == [], "docs/api is stale: run python -m docs.api"


def test_every_page_of_the_api_reference_is_written(tmp_path):
    names = api.write(tmp_path)
    assert names == sorted(["index.md", "render.md"] + [f"{p}.md" for p in api.PACKAGES])
    index = (tmp_path / "index.md").read_text()
    import raycast_shade as rs

    for name in rs.__all__:
        assert f"`{name}" in index, name
    for page in names:
        assert (tmp_path / page).read_text().startswith("# ")


def test_no_reference_names_nothing():
    bad = sorted({(path, ref) for path, _, ref in api.dangling()} - KNOWN)
    assert not bad, "dangling references: " + "; ".join(f"{p}: {r}" for p, r in bad)


@pytest.mark.parametrize("ref, ok", [
    ("raycast_shade.output.tonemap.to_uint8", True), ("raycast_shade.tonemap.to_uint8", False),
    ("raycast_shade.Scene", True), ("raycast_shade.scene.Scene", False), ("raycast_shade.scene.scene.Scene.replace", True),
])
def test_dotted_references_resolve_as_imports_do(ref, ok):
    assert api._resolve_dotted(ref) is ok


@pytest.mark.parametrize("target, module, ok", [
    ("to_uint8", "raycast_shade.output.frame", True),          # a unique name of the package
    (".tonemap.to_uint8", "raycast_shade.output.frame", True),  # relative to the module's package
    ("save", "raycast_shade.output.frame", True),               # a member of the module's class
    ("numpy.ndarray", None, True),                              # outside the project: not checked
    ("no_such_function", "raycast_shade.output.frame", False),
    (".no_such_module", "raycast_shade.output.frame", False),
])
def test_sphinx_roles_resolve_like_sphinx_finds_them(target, module, ok):
    assert api._resolve_role(target, module) is ok


def test_markdown_links_and_repository_paths_are_checked():
    line = "see [a](no_such_page.md) and `benchmarks/no_such.py`, [b](architecture.md), `tests/README.md`"
    links = [m.group(1) for m in api.LINK.finditer(line)]
    paths = [m.group(1) for m in api.REPO_PATH.finditer(line)]
    assert links == ["no_such_page.md", "architecture.md"] and paths == ["benchmarks/no_such.py", "tests/README.md"]
    docs = os.path.join(ROOT, "docs")
    assert not os.path.exists(os.path.join(docs, links[0])) and os.path.exists(os.path.join(docs, links[1]))
