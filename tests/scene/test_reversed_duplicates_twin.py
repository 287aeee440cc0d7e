"""``reversed_duplicates`` against a plain-Python twin on random small meshes (welded positions, degenerate
triples, repeats in either winding), so its fast sort-based search cannot drift from the definition."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from raycast_shade.scene.normals import reversed_duplicates


def _twin(faces, vertices=None):
    """The definition, literally: the later face of each pair that repeats an earlier one reversed."""
    if vertices is not None:
        first = {}
        ids = [first.setdefault(tuple(p), len(first)) for p in np.asarray(vertices, float).tolist()]
        faces = [[ids[i] for i in f] for f in faces]
    out, open_ = [], []
    for f in faces:
        f = [int(i) for i in f]
        if len(set(f)) < 3:
            out.append(False)
            continue
        rotations = {tuple(f[k:] + f[:k]) for k in range(3)}
        reverse = tuple(reversed(f))
        reverse_rotations = {reverse[k:] + reverse[:k] for k in range(3)}
        match = next((j for j, g in enumerate(open_) if g in reverse_rotations), None)
        if match is not None:
            open_.pop(match)
            out.append(True)
        else:
            open_.append(min(rotations))
            out.append(False)
    return np.array(out, bool)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(st.integers(3, 9).flatmap(lambda n: st.tuples(
    st.lists(st.tuples(*[st.integers(0, n - 1)] * 3), min_size=1, max_size=25),
    st.lists(st.tuples(*[st.integers(0, 2)] * 3), min_size=n, max_size=n))))
def test_reversed_duplicates_equal_their_plain_twin(case):
    faces, positions = case
    f = np.array(faces, np.int64)
    v = np.array(positions, float)
    np.testing.assert_array_equal(reversed_duplicates(f), _twin(f))
    np.testing.assert_array_equal(reversed_duplicates(f, v), _twin(f, v))
