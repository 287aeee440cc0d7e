"""common/frontend.py: Numba's front end, cheaper, with Numba's answers: NumPy's operator typing
declines scalars before looking for a ufunc loop; an IR instruction's variables are listed in one
pass, the same variables in the same order as Numba's."""

from __future__ import annotations

import operator

import numba
import numpy as np
import pytest
from numba.core import ir

from raycast_shade.common import frontend


def test_both_are_installed_on_this_numba():
    assert frontend.SCALAR_OPERATORS and frontend.LIST_VARS
    assert ir.Inst._rec_list_vars is frontend._rec_list_vars


def _template(base, op):
    """NumPy's typing template of operator ``op`` (a subclass of ``base`` keyed on it)."""
    return next(c for c in base.__subclasses__() if getattr(c, "key", None) is op)


def test_numpys_operator_typing_declines_scalars_without_looking_for_a_ufunc_loop(monkeypatch):
    from numba.core import types
    from numba.core.typing import npydecl
    from numba.core.registry import cpu_target

    looked = []
    numbas = npydecl.ufunc_find_matching_loop

    def spy(ufunc, arg_types):
        looked.append(ufunc.__name__)
        return numbas(ufunc, arg_types)

    monkeypatch.setattr(npydecl, "ufunc_find_matching_loop", spy)
    ctx = cpu_target.typing_context
    add = _template(npydecl.NumpyRulesArrayOperator, operator.add)(ctx)
    neg = _template(npydecl.NumpyRulesUnaryArrayOperator, operator.neg)(ctx)
    assert add.generic((types.float64, types.int64), {}) is None
    assert neg.generic((types.float32,), {}) is None
    assert looked == []  # Numba's: a ufunc loop looked for, then declined
    arr = types.Array(types.float64, 1, "C")
    assert add.generic((arr, types.int64), {}).return_type == arr
    assert add.generic((types.Optional(arr), types.float64), {}).return_type == arr
    assert looked == ["add", "add"]


def test_array_and_scalar_arithmetic_still_compiles():
    @numba.njit(cache=False)
    def f(a, x):
        return -(a + x) * 2.0, x * 3 - 1

    arr, s = f(np.arange(3.0), 2)
    assert arr.tolist() == [-4.0, -6.0, -8.0] and s == 5


def _statements(func):
    """Every statement and expression of ``func``'s Numba IR (untyped, as the passes see it)."""
    from numba.core import compiler

    fir = compiler.run_frontend(func)
    for block in fir.blocks.values():
        for stmt in block.body:
            yield stmt
            for value in stmt.__dict__.values():
                if isinstance(value, ir.Inst):
                    yield value


def _kernel_like(a, b, n):
    s = 0.0
    t = (a[0], (a[1], b[0]), [n, n + 1])
    for i in range(n):
        x, y = a[i], b[i]
        s += x * y - min(x, y) if x > 0 else np.sqrt(abs(y)) + t[1][0]
    d = {"k": s}
    return s, t, d["k"], (lambda q: q + 1)(n)


def test_the_variables_listed_are_numbas_in_numbas_order():
    from raycast_shade.shading import mirrors, phong

    numbas = ir.Inst._numbas_rec_list_vars
    funcs = [_kernel_like, phong._surface.py_func, mirrors._make_packets(False).py_func]
    checked = 0
    for func in funcs:
        for inst in _statements(func):
            for val in (inst.__dict__, list(inst.__dict__.values()), tuple(inst.__dict__.items())):
                ours, theirs = frontend._rec_list_vars(inst, val), numbas(inst, val)
                assert [v.name for v in ours] == [v.name for v in theirs]
                assert all(a is b for a, b in zip(ours, theirs))
                checked += bool(theirs)
    assert checked > 300


def _questions():
    """(function type, argument types) pairs as type inference asks them: operators, builtins,
    math, and Numba overloads of NumPy (``np.empty``, ``np.sqrt``), with literals among them."""
    import math

    from numba.core import types
    from numba.core.registry import cpu_target

    ctx = cpu_target.typing_context
    f64, i64, i32 = types.float64, types.int64, types.int32
    arr = types.Array(types.float64, 2, "C")
    tup = types.UniTuple(f64, 3)
    asks = [(operator.add, (f64, i64)), (operator.add, (i32, i64)), (operator.mul, (arr, f64)),
            (operator.lt, (f64, f64)), (operator.getitem, (arr, types.UniTuple(i64, 2))),
            (operator.getitem, (tup, types.IntegerLiteral(1))), (operator.neg, (f64,)), (min, (f64, i64)),
            (max, (i64, i64)), (abs, (f64,)), (math.sqrt, (f64,)), (np.sqrt, (f64,)),
            (np.empty, (types.UniTuple(i64, 2), types.NumberClass(f64))), (len, (tup,))]
    return ctx, [(ctx.resolve_value_type(fn), args) for fn, args in asks]


def test_a_call_is_typed_as_numbas_search_types_it_first_and_again():
    from numba.core import types

    assert frontend.CALL_TEMPLATES
    numbas = types.functions.BaseFunction._numbas_get_call_type
    ctx, questions = _questions()
    for fnty, args in questions:
        theirs = numbas(fnty, ctx, args, {})
        first = fnty.get_call_type(ctx, args, {})
        again = fnty.get_call_type(ctx, args, {})  # from the template that answered
        assert theirs is not None and first == theirs and again == theirs, (fnty, args)
        assert fnty.get_impl_key(again) == fnty.get_impl_key(theirs)


def test_asked_again_no_template_before_the_answering_one_is_asked(monkeypatch):
    from numba.core import types

    ctx, questions = _questions()
    fnty, args = questions[0]  # a float plus an int: NumPy's and others' templates decline first
    fnty.get_call_type(ctx, args, {})
    declined = []
    numbas = types.functions._ResolutionFailures.add_error
    monkeypatch.setattr(types.functions._ResolutionFailures, "add_error",
                        lambda self, *a: (declined.append(a[0]), numbas(self, *a))[1])
    types.functions.BaseFunction._numbas_get_call_type(fnty, ctx, args, {})
    assert declined  # Numba's search: templates decline before the answer
    declined.clear()
    assert fnty.get_call_type(ctx, args, {}) is not None
    assert declined == []


def test_a_call_no_template_answers_raises_numbas_error():
    from numba.core import errors, types
    from numba.core.registry import cpu_target

    ctx = cpu_target.typing_context
    fnty = ctx.resolve_value_type(operator.add)
    with pytest.raises(errors.TypingError):
        fnty.get_call_type(ctx, (types.unicode_type, types.float64), {})
