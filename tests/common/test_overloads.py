"""common/overloads.py: one build of an overload per set of flags it inherits, shared by callers
whose flags differ otherwise; callers that differ in an inherited flag still get their own."""

from __future__ import annotations

import numba
import pytest
from numba.core.typing import templates
from numba.extending import overload

from raycast_shade.common import overloads
from raycast_shade.common.inline import inline_jit


def _make():
    builds = []

    def twice(x):
        raise NotImplementedError

    @overload(twice)
    def _ol_twice(x):
        builds.append(x)

        def impl(x):
            return 2 * x + 1

        return impl

    return twice, builds


def test_the_key_is_installed_on_this_numba():
    assert overloads.INSTALLED
    assert templates._OverloadFunctionTemplate._get_impl is overloads._get_impl


def test_callers_differing_in_flags_the_overload_does_not_inherit_share_one_build():
    twice, builds = _make()

    @numba.njit(cache=False)
    def plain(x):
        return twice(x)

    @numba.njit(cache=False, nogil=True)
    def released(x):
        return twice(x) + 1

    @inline_jit(cache=False)
    def helper(x):
        return twice(x) - 1

    @numba.njit(cache=False)
    def calls_helper(x):
        return helper(x)

    assert plain(3) == 7 and released(3) == 8 and calls_helper(3) == 6
    # Three callers, three different Flags (release_gil, no_cpython_wrapper...), one build for
    # int64 (Numba's own key built it once per caller's flags).
    assert [str(t) for t in builds] == ["int64"]


@pytest.mark.parametrize("options", [{"fastmath": True}, {"error_model": "numpy"}, {"_nrt": False}])
def test_a_caller_differing_in_an_inherited_flag_gets_its_own_build(options):
    twice, builds = _make()

    @numba.njit(cache=False)
    def plain(x):
        return twice(x)

    @numba.njit(cache=False, **options)
    def other(x):
        return twice(x)

    assert plain(2.5) == 6.0 and other(2.5) == 6.0
    assert [str(t) for t in builds] == ["float64", "float64"]
