"""common/frontend.py: Numba's front end, cheaper, with Numba's answers: NumPy's operator typing
declines scalars before looking for a ufunc loop; an IR instruction's variables are listed in one
pass, the same variables in the same order as Numba's."""

from __future__ import annotations

import gc
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


def _entry_vars(func, eager):
    """``{block offset: live variables on entry}`` of ``func``'s IR post-processed by ours (lazy)
    or by Numba's own post-processor (eager)."""
    from numba.core import compiler, postproc

    if eager:
        ours = postproc.PostProcessor.run
        postproc.PostProcessor.run = postproc.PostProcessor._numbas_run
        try:
            fir = compiler.run_frontend(func)
        finally:
            postproc.PostProcessor.run = ours
        assert type(fir.block_entry_vars) is dict
    else:
        fir = compiler.run_frontend(func)
        assert isinstance(fir.block_entry_vars, frontend._EntryVars) and fir.block_entry_vars._pending
    return {k: set(fir.get_block_entry_vars(b)) for k, b in fir.blocks.items()}


def test_entry_vars_are_numbas_when_read():
    from raycast_shade.shading import mirrors, phong

    assert frontend.LAZY_ENTRY_VARS
    funcs = [_kernel_like, phong._surface.py_func, mirrors._make_packets(False).py_func]
    live = 0
    for func in funcs:
        ours, theirs = _entry_vars(func, False), _entry_vars(func, True)
        assert ours == theirs
        live += sum(map(len, theirs.values()))
    assert live > 100


def test_a_nopython_compile_computes_live_variables_only_for_the_del_passes(monkeypatch):
    from numba.core import analysis, postproc

    counts = {"live": 0, "numbas": 0}
    live, numbas = analysis.compute_live_variables, postproc.PostProcessor._numbas_run
    monkeypatch.setattr(analysis, "compute_live_variables",
                        lambda *a: (counts.__setitem__("live", counts["live"] + 1), live(*a))[1])
    monkeypatch.setattr(postproc.PostProcessor, "_numbas_run",
                        lambda self, *a: (counts.__setitem__("numbas", counts["numbas"] + 1), numbas(self, *a))[1])
    frontend.install_lazy_entry_vars()  # around the spies
    try:
        @numba.njit(cache=False)
        def f(a):
            s = 0.0
            for i in range(a.shape[0]):
                s += a[i] if a[i] > 0 else -a[i]
            return s

        assert f(np.array([1.0, -2.0, 3.0])) == 6.0
    finally:
        monkeypatch.undo()
        frontend.install_lazy_entry_vars()
    assert counts["numbas"] >= 1 and counts["live"] == counts["numbas"]  # Numba's post-processor alone computed them


def test_object_mode_generators_and_objmode_blocks_still_compile():
    @numba.jit(forceobj=True, cache=False)
    def obj(xs):
        out = []
        for x in xs:
            if x > 1:
                out.append(str(x))
        return ",".join(out)

    @numba.njit(cache=False)
    def gen(n):
        for i in range(n):
            if i % 2:
                yield i * i

    @numba.njit(cache=False)
    def with_objmode(x):
        with numba.objmode(y="float64"):
            y = float(np.round(x * 10.0)) / 10.0
        return y + 1.0

    assert obj([0, 2, 3]) == "2,3"
    assert list(gen(6)) == [1, 9, 25]
    assert with_objmode(1.234) == 2.2


def test_a_table_of_signatures_answers_again_without_choosing_again(monkeypatch):
    """A call answered by a ConcreteTemplate (a table of signatures: ``a + b`` of two numbers) gets
    the same signature again without the table being searched again; the lowering's key is set."""
    from numba.core import types
    from numba.core.registry import cpu_target

    ctx = cpu_target.typing_context
    fnty = ctx.resolve_value_type(operator.add)
    args = (types.int32, types.float32)
    first = fnty.get_call_type(ctx, args, {})
    searched = []
    numbas = type(ctx).resolve_overload
    monkeypatch.setattr(type(ctx), "resolve_overload", lambda self, *a, **k: (searched.append(a[0]),
                                                                              numbas(self, *a, **k))[1])
    fnty._impl_keys.pop(first.args, None)
    again = fnty.get_call_type(ctx, args, {})
    assert again == first == types.float64(types.float64, types.float64) and searched == []
    assert fnty.get_impl_key(again) is operator.add


def test_an_llvm_types_size_and_alignment_are_llvmlites():
    """The answers kept per type and layout equal llvmlite's own, asked again (parsing a module)."""
    from llvmlite import ir as llvmir
    from numba.core import base
    from numba.core.registry import cpu_target

    assert frontend.ABI_SIZES
    ctx = cpu_target.target_context
    i8p = llvmir.IntType(8).as_pointer()
    kinds = [llvmir.IntType(1), llvmir.IntType(64), llvmir.DoubleType(), llvmir.ArrayType(llvmir.FloatType(), 3),
             llvmir.LiteralStructType([i8p, i8p, llvmir.IntType(64), llvmir.IntType(64), llvmir.DoubleType().as_pointer(),
                                       llvmir.ArrayType(llvmir.IntType(64), 2), llvmir.ArrayType(llvmir.IntType(64), 2)]),
             llvmir.LiteralStructType([llvmir.IntType(8), llvmir.DoubleType(), llvmir.IntType(16)])]
    for ty in kinds + kinds:  # the second time from the kept answers
        assert ctx.get_abi_sizeof(ty) == ty.get_abi_size(ctx.target_data)
        assert ctx.get_abi_alignment(ty) == ty.get_abi_alignment(ctx.target_data)
    assert [ctx.get_abi_sizeof(t) for t in kinds] == [1, 8, 8, 12, 72, 24]
    assert base.BaseContext._numbas_get_abi_sizeof is not base.BaseContext.get_abi_sizeof


def test_a_literal_type_is_asked_once_a_named_struct_every_time(monkeypatch):
    """A literal type's answer is kept; a named struct's text does not spell out its body, so
    llvmlite is asked every time."""
    from llvmlite import ir as llvmir
    from numba.core import base
    from numba.core.registry import cpu_target

    asked = []
    numbas = base.BaseContext._numbas_get_abi_sizeof

    def spy(self, ty):
        asked.append(str(ty))
        return numbas(self, ty)

    monkeypatch.setattr(base.BaseContext, "_numbas_get_abi_sizeof", spy)
    frontend.install_abi_sizes()  # wraps the spy (Numba's, as installed)
    try:
        ctx = cpu_target.target_context
        named = llvmir.global_context.get_identified_type("rs_test_named_struct")
        if named.is_opaque:
            named.set_body(llvmir.IntType(32), llvmir.DoubleType())
        assert ctx.get_abi_sizeof(named) == ctx.get_abi_sizeof(named) == 16
        assert asked.count(str(named)) == 2
        odd = llvmir.LiteralStructType([llvmir.IntType(8), llvmir.IntType(8), llvmir.IntType(8), llvmir.FloatType()])
        assert ctx.get_abi_sizeof(odd) == ctx.get_abi_sizeof(odd) == 8
        assert asked.count(str(odd)) == 1
    finally:
        monkeypatch.undo()
        frontend.install_abi_sizes()


def _thresholds_while_compiling(fn, *args):
    """The collector's thresholds seen from inside each compile of ``fn(*args)``."""
    from numba.core import event

    seen = []

    class Seen(event.Listener):
        def on_start(self, ev):
            seen.append(gc.get_threshold())

        def on_end(self, ev):
            pass

    with event.install_listener("numba:compile", Seen()):
        try:
            fn(*args)
        except Exception as e:  # a compile that fails: the thresholds come back all the same
            seen.append(type(e).__name__)
    return seen


def test_a_compile_runs_with_the_higher_threshold_and_gives_back_the_callers():
    assert frontend.COMPILE_GC
    kept = gc.get_threshold()
    try:
        gc.set_threshold(1234, 5, 6)

        @numba.njit(cache=False)
        def inner(x):
            return x + 1

        @numba.njit(cache=False)
        def outer(x):
            return inner(x) * 2

        seen = _thresholds_while_compiling(outer, 3)
        assert len(seen) >= 2  # outer, and inner inside it
        assert all(t == (frontend.COMPILE_GC_THRESHOLD, 5, 6) for t in seen), seen
        assert gc.get_threshold() == (1234, 5, 6)
        assert outer(3) == 8

        @numba.njit(cache=False)
        def broken(x):
            return x.no_such_attribute

        seen = _thresholds_while_compiling(broken, 1)
        assert seen[-1] == "TypingError" and seen[0] == (frontend.COMPILE_GC_THRESHOLD, 5, 6)
        assert gc.get_threshold() == (1234, 5, 6)

        gc.set_threshold(50_000, 7, 8)  # higher than ours: left alone

        @numba.njit(cache=False)
        def other(x):
            return x - 1

        assert set(_thresholds_while_compiling(other, 3)) == {(50_000, 7, 8)}
        assert gc.get_threshold() == (50_000, 7, 8)
    finally:
        gc.set_threshold(*kept)


def test_releasing_a_lock_not_held_raises_as_numba_does_and_keeps_the_thresholds():
    from numba.core.compiler_lock import global_compiler_lock

    kept = gc.get_threshold()
    with pytest.raises(RuntimeError):
        global_compiler_lock.release()
    assert gc.get_threshold() == kept
