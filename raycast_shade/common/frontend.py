"""Numba's front end, cheaper where it repeats work on every line it compiles.

Most of a cold start's CPU is Numba's own Python: type inference and lowering, line by line, of
every kernel and helper (docs/performance.md, "Cold start"). Two of its steps cost far more than
their answers need, on every line, and are replaced here by equivalents that give the same answers
(so the same types and the same code), for the Numba versions checked (:data:`CHECKED`):

- :func:`install_scalar_operators`: NumPy's typing of ``+``, ``<``, ``-x`` ... declines operands
  without an array before it looks for a ufunc loop;
- :func:`install_list_vars`: the variables an IR statement uses, listed without a recursive call
  and four ``isinstance`` tests per attribute (Numba lists them again after every pass that
  changes the IR, for its use-def maps);
- :func:`install_lazy_entry_vars`: the variables live on entry to each block, which Numba's IR
  post-processor computes after every pass that changes the IR and only object-mode lowering and
  generators read, computed when first read;
- :func:`install_call_templates`: a call typed before (the same function, argument types,
  context and inherited flags) is asked of the template that answered it, not of every template
  in turn;
- :func:`install_abi_sizes`: the size and alignment of an LLVM type, which the lowering asks for
  every array and record it builds, answered once per type instead of by parsing a module;
- :func:`install_compile_gc`: while Numba compiles, Python's cyclic garbage collector runs less
  often (a compile allocates millions of objects that live until it ends, and each collection of
  the oldest generation walked every object of the process, Numba's, NumPy's and SciPy's
  included).

Measured on the demo's flat first picture from an empty cache (sampled profile, 2026-12-06): the
ufunc-loop look-ups of scalar operators took 3-4% of all the CPU, the listing of variables 4-5%;
the template search for calls typed before about 5% (the picture's CPU against the code without
it, six rounds run side by side, one per core: 0.94-0.96) and the tables' choice again about 3%
(eight rounds, median 0.97); the variables live on entry to each block about 3.5% (four rounds,
0.94-0.975).
"""

from __future__ import annotations

import gc

import numba
from numba.core import analysis, errors, ir, targetconfig, types, utils
from numba.core.types import functions as _functions
from numba.core.typing import npydecl
from numba.core.typing.templates import ConcreteTemplate as _CONCRETE

from .overloads import _inherited

__all__ = ["replace", "install_scalar_operators", "install_list_vars", "install_call_templates",
           "install_lazy_entry_vars", "install_abi_sizes", "install_compile_gc", "COMPILE_GC_THRESHOLD", "CHECKED"]

CHECKED = ("0.68",)  # the Numba versions whose code the replacements were checked against


def replace(cls, name: str, make) -> bool:
    """Put ``make(numbas)`` in place of ``cls.name``, Numba's own kept as ``cls._numbas_<name>``
    (``name`` without its leading underscore) and handed to ``make``; installing again wraps
    Numba's, not the last replacement. Only for the Numba versions checked (:data:`CHECKED`).

    Returns
    -------
    bool
        Whether it is installed.
    """
    if not numba.__version__.startswith(CHECKED):
        return False
    keep = "_numbas_" + name.lstrip("_")
    numbas = getattr(cls, keep, getattr(cls, name))
    setattr(cls, keep, numbas)
    setattr(cls, name, make(numbas))
    return True


def _no_array(args) -> bool:
    return not any(isinstance(a.type if isinstance(a, types.Optional) else a, types.ArrayCompatible) for a in args)


def install_scalar_operators() -> bool:
    """Let NumPy's typing of the arithmetic and comparison operators (``a + b``, ``-a``, ``a < b``:
    ``NumpyRulesArrayOperator``) decline operands without an array at once.

    Type inference asks every template of an operator, in turn, for each ``+``, ``*``, ``<`` ...
    of our code, and NumPy's template, asked about two scalars, first finds the NumPy loop the
    ufunc would take (``ufunc_find_matching_loop``, casting rules and all), and only then declines
    them because neither is an array: a tenth of the demo's type inference. It declines them
    before that now; what it answers for operands with an array (an ``Optional`` of one
    included: Numba types the loop on the array inside) is Numba's. Only for the Numba versions
    checked (:data:`CHECKED`).

    Returns
    -------
    bool
        Whether the shortcut is installed.
    """
    def make(numbas):
        def generic(self, args, kws):
            if not kws and _no_array(args):
                return None
            return numbas(self, args, kws)
        return generic

    return replace(npydecl.NumpyRulesArrayOperator, "generic", make)


def _kind(t) -> int:
    """What :func:`_collect` does with a value of type ``t``: 1 a variable, 2 an instruction
    (its own ``list_vars``), 3 a sequence, 4 a mapping, 0 nothing (Numba's ``isinstance`` order)."""
    if issubclass(t, ir.Var):
        k = 1
    elif issubclass(t, ir.Inst):
        k = 2
    elif issubclass(t, (list, tuple)):
        k = 3
    elif issubclass(t, dict):
        k = 4
    else:
        k = 0
    _KINDS[t] = k
    return k


_KINDS: dict = {}


def _collect(val, out) -> None:
    k = _KINDS.get(type(val))
    if k is None:
        k = _kind(type(val))
    if k == 1:
        out.append(val)
    elif k == 2:
        out.extend(val.list_vars())
    elif k == 3:
        for v in val:
            _collect(v, out)
    elif k == 4:
        for v in val.values():
            _collect(v, out)


def _rec_list_vars(self, val):
    # Numba's ir.Inst._rec_list_vars: the same variables in the same order, one list.
    out = []
    _collect(val, out)
    return out


def install_list_vars() -> bool:
    """List an IR instruction's variables (``ir.Inst._rec_list_vars``, behind every ``list_vars``)
    in one pass into one list, each value's kind looked up by its type, instead of a recursive call
    that tests the value against four classes and concatenates a list per level.

    Returns
    -------
    bool
        Whether it is installed (only for the Numba versions checked).
    """
    return replace(ir.Inst, "_rec_list_vars", lambda numbas: _rec_list_vars)


def install_call_templates() -> bool:
    """Type a call of a Numba function (``+``, ``a[i]``, ``min``, ``np.empty``, ...) by asking the
    template that answered the same question before, not every template in turn.

    Numba asks a function's templates in order for every call it types and keeps the first answer;
    the templates before it fail, each failure formatted into a message that is dropped with the
    answer. The same question (the function, the argument types, the context and the flags a
    build inherits) asked again gets its answer from the template that gave it: a table of
    signatures (``ConcreteTemplate``: ``+`` of two numbers, ``abs``, ...) records nothing and answers
    the same, so its answer is kept; any other template is asked again (so that what it records
    for the lowering, an overload's build, is recorded as Numba records it), and should it decline
    now, Numba's search runs.

    Returns
    -------
    bool
        Whether it is installed (only for the Numba versions checked).
    """
    winners: dict = {}

    def _ask(temp, args, kws, uselit):
        if uselit:
            return temp.apply(args, kws)
        return temp.apply(tuple(_functions._unlit_non_poison(a) for a in args),
                          {k: _functions._unlit_non_poison(v) for k, v in kws.items()})

    def get_call_type(self, context, args, kws):
        try:
            flags = _inherited(targetconfig.ConfigStack.top_or_none())  # what an overload's build inherits
            key = (self, context, tuple(args), tuple(kws.items()), flags)
            won = winners.get(key)
        except TypeError:  # an unhashable argument type: Numba's search
            return _functions.BaseFunction._numbas_get_call_type(self, context, args, kws)
        if won is not None and won[2] is not None:  # a table of signatures: the same answer
            sig = won[2]
            self._impl_keys[sig.args] = won[0](context).get_impl_key(sig)
            return sig
        if won is not None:  # the template that answered before, asked again
            temp = won[0](context)
            try:
                sig = _ask(temp, args, kws, won[1])
            except errors.NumbaError:
                sig = None
            if sig is not None:
                self._impl_keys[sig.args] = temp.get_impl_key(sig)
                return sig
        # Numba's search (BaseFunction.get_call_type, Numba 0.68), noting the template that answers.
        prefer_lit = [True, False]
        prefer_not = [False, True]
        failures = _functions._ResolutionFailures(context, self, args, kws, depth=self._depth)
        from numba.core.target_extension import get_local_target
        target_hw = get_local_target(context)
        order = utils.order_by_target_specificity(target_hw, self.templates, fnkey=self.key[0])
        self._depth += 1
        for temp_cls in order:
            temp = temp_cls(context)
            for uselit in (prefer_lit if temp.prefer_literal else prefer_not):
                try:
                    sig = _ask(temp, args, kws, uselit)
                except Exception as e:
                    if not isinstance(e, errors.NumbaError):
                        raise e
                    sig = None
                    failures.add_error(temp, False, e, uselit)
                else:
                    if sig is not None:
                        self._impl_keys[sig.args] = temp.get_impl_key(sig)
                        self._depth -= 1
                        # A table of signatures (ConcreteTemplate) answers the same again and records
                        # nothing: its answer is kept; any other template is asked again.
                        winners[key] = (temp_cls, uselit, sig if issubclass(temp_cls, _CONCRETE) else None)
                        return sig
                    registered_sigs = getattr(temp, "cases", None)
                    if registered_sigs is not None:
                        msg = "No match for registered cases:\n%s" % "\n".join(
                            " * {}".format(x) for x in registered_sigs)
                    else:
                        msg = "No match."
                    failures.add_error(temp, True, msg, uselit)
        failures.raise_error()

    return replace(_functions.BaseFunction, "get_call_type", lambda numbas: get_call_type)


class _EntryVars(dict):
    """``FunctionIR.block_entry_vars`` whose entries for the blocks of the last post-processing are
    computed when first read (Numba's :func:`~numba.core.analysis.compute_live_variables`, from that
    post-processing's variable lifetimes). A write (an eager post-processing, Numba's, which sets
    the entries of all its blocks) drops the pending ones."""

    __slots__ = ("_pending",)

    def __init__(self, entries, pending):
        super().__init__(entries)
        self._pending = pending

    def _fill(self):
        pending = self._pending
        if pending is not None:
            self._pending = None
            vlt, blocks = pending
            live = analysis.compute_live_variables(vlt.cfg, blocks, vlt.usedefs.defmap, vlt.deadmaps.combined)
            for offset, block in blocks.items():
                dict.__setitem__(self, block, live[offset])

    def __setitem__(self, key, value):
        self._pending = None  # an eager post-processing (Numba's) sets the entries of every block it has
        dict.__setitem__(self, key, value)

    __hash__ = None  # (a dict's: it defines __eq__)

    def copy(self):
        self._fill()
        return dict(self)

    def __reduce__(self):
        self._fill()
        return dict, (dict(self),)


def _filled_first(name):
    """``dict.<name>``, the pending entries filled first."""
    read = getattr(dict, name)

    def method(self, *args):
        self._fill()
        return read(self, *args)

    method.__name__, method.__qualname__ = name, f"_EntryVars.{name}"
    return method


# Every read of the entries fills the pending ones first.
for _read in ("__getitem__", "__contains__", "__iter__", "__len__", "__eq__", "get", "keys", "values", "items"):
    setattr(_EntryVars, _read, _filled_first(_read))
del _read


def install_lazy_entry_vars() -> bool:
    """Numba's IR post-processor (``PostProcessor.run``, after every pass that changes the IR)
    leaves the variables live on entry to each block to be computed when first read.

    The post-processor canonicalises the control flow, attaches the variables' lifetimes (lazy
    already) and fills ``func_ir.block_entry_vars``, the variables live on entry to each block, which
    needs the use-def, live and dead maps of the whole function, on every call: 838 times on the
    demo's flat first picture, 3.6% of its CPU. Only object-mode lowering and generators read those
    entries, and both come after a post-processing that emits ``del`` statements, which stays
    Numba's own (as does every post-processing of a generator). Here the entries are filled when
    first read, from that post-processing's lifetimes and blocks: a reader gets Numba's values.

    Returns
    -------
    bool
        Whether it is installed (only for the Numba versions checked).
    """
    from numba.core import postproc, transforms

    def make(numbas):
        def run(self, emit_dels: bool = False, extend_lifetimes: bool = False):
            fir = self.func_ir
            if emit_dels or fir.is_generator:
                return numbas(self, emit_dels, extend_lifetimes)
            fir.blocks = transforms.canonicalize_cfg(fir.blocks)
            vlt = postproc.VariableLifetime(fir.blocks)
            fir.variable_lifetime = vlt
            entries = fir.block_entry_vars
            if isinstance(entries, _EntryVars):
                entries._pending = (vlt, fir.blocks)  # supersedes a pending one: readers read the latest blocks
            else:
                fir.block_entry_vars = _EntryVars(entries, (vlt, fir.blocks))
            fir.generator_info = None
            return None
        return run

    return replace(postproc.PostProcessor, "run", make)


def install_abi_sizes() -> bool:
    """Answer the lowering's questions about an LLVM type's ABI size and alignment
    (``BaseContext.get_abi_sizeof``, ``get_abi_alignment``) once per type and context.

    llvmlite answers each by writing a module that holds one global of the type, parsing it and
    asking the parsed type: 813 modules parsed on the demo's flat first picture, 1.3% of its CPU,
    for 31 distinct types. The answer depends only on the type, which its text spells out in full,
    and on the data layout, so it is kept per layout (the codegen's, which the contexts Numba copies
    share) under the text; a named struct (``%"..."`` in the text, its body elsewhere) is asked anew
    each time, as Numba asks it.

    Returns
    -------
    bool
        Whether it is installed (only for the Numba versions checked).
    """
    from numba.core import base

    answers: dict = {}
    layouts: dict = {}

    def memo(kind):
        def make(numbas):
            def ask(self, ty):
                text = str(ty)  # llvmlite keeps a type's text
                if "%" in text:
                    return numbas(self, ty)
                layout = self.target_data  # one per codegen, shared by the contexts Numba copies
                key = id(layout), kind, text
                ans = answers.get(key)
                if ans is None:
                    ans = numbas(self, ty)
                    answers[key] = ans
                    layouts[id(layout)] = layout  # kept alive: its id is never another's
                return ans
            return ask
        return make

    return (replace(base.BaseContext, "get_abi_sizeof", memo("size"))
            and replace(base.BaseContext, "get_abi_alignment", memo("align")))


# The collector's first threshold (allocations net of frees between collections of the youngest
# generation; Python's is 700) while Numba compiles. Measured on the demo's flat first picture from
# an empty cache (2026-12-06, 2-core Intel Xeon), the collector's CPU: 2.05 s with Python's
# thresholds (ten collections of every object in the process, 1.55 s), 0.98 s with 3,000, 0.63 s
# with 10,000, 0.80 s with 30,000 and 0.87 s with 100,000 (fewer collections, each walking more
# young objects); the process's peak memory 271 MB, 276 MB with 10,000.
COMPILE_GC_THRESHOLD = 10_000


def install_compile_gc() -> bool:
    """Raise the garbage collector's first threshold to :data:`COMPILE_GC_THRESHOLD` while
    Numba's compiler lock is held (every compile, and nothing else: a compiled function's call
    does not take it), and put back whatever thresholds were set once the lock is released.

    A compile builds Numba's IR, types and LLVM IR, millions of objects that live until it ends:
    with Python's thresholds the collector ran 1,317 times on the demo's flat first picture, ten of
    them over every object of the process, for 15% of its CPU. Nothing changes what is compiled.
    Thresholds set higher than this one are left alone, and so is a collector that is switched off.

    Returns
    -------
    bool
        Whether it is installed (only for the Numba versions checked).
    """
    from numba.core import compiler_lock

    def make_acquire(numbas):
        def acquire(self):
            numbas(self)
            depth = getattr(self, "_gc_depth", 0) + 1  # changed only by the thread holding the lock
            self._gc_depth = depth
            if depth == 1:
                kept = gc.get_threshold()
                self._gc_kept = kept
                if kept[0] < COMPILE_GC_THRESHOLD:
                    gc.set_threshold(COMPILE_GC_THRESHOLD, *kept[1:])
        return acquire

    def make_release(numbas):
        def release(self):
            if self.is_locked():  # held by this thread: else Numba's release raises
                self._gc_depth -= 1
                if self._gc_depth == 0:
                    gc.set_threshold(*self._gc_kept)
            numbas(self)
        return release

    cls = compiler_lock._CompilerLock
    return replace(cls, "acquire", make_acquire) and replace(cls, "release", make_release)


SCALAR_OPERATORS = install_scalar_operators()
LIST_VARS = install_list_vars()
CALL_TEMPLATES = install_call_templates()
LAZY_ENTRY_VARS = install_lazy_entry_vars()
ABI_SIZES = install_abi_sizes()
COMPILE_GC = install_compile_gc()
