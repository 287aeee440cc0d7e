"""Numba's front end, cheaper where it repeats work on every line it compiles.

Most of a cold start's CPU is Numba's own Python: type inference and lowering, line by line, of
every kernel and helper (docs/performance.md, "Cold start"). Two of its steps cost far more than
their answers need, on every line, and are replaced here by equivalents that give the same answers
(so the same types and the same code), for the Numba versions checked (:data:`CHECKED`):

- :func:`install_scalar_operators`: NumPy's typing of ``+``, ``<``, ``-x`` ... declines operands
  without an array before it looks for a ufunc loop;
- :func:`install_list_vars`: the variables an IR statement uses, listed without a recursive call
  and four ``isinstance`` tests per attribute (Numba lists them again after every pass that
  changes the IR, for its use-def maps).

Measured on the demo's flat first picture from an empty cache (sampled profile, 2026-12-06): the
ufunc-loop look-ups of scalar operators took 3-4% of all the CPU, the listing of variables 4-5%.
"""

from __future__ import annotations

import numba
from numba.core import ir, types
from numba.core.typing import npydecl

__all__ = ["install_scalar_operators", "install_list_vars", "CHECKED"]

CHECKED = ("0.68",)  # the Numba versions whose code the replacements were checked against


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
    cls = npydecl.NumpyRulesArrayOperator
    if not numba.__version__.startswith(CHECKED):
        return False
    numbas = getattr(cls, "_numbas_generic", cls.generic)  # installed once

    def generic(self, args, kws):
        if not kws and _no_array(args):
            return None
        return numbas(self, args, kws)

    cls._numbas_generic = numbas
    cls.generic = generic
    return True


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
    if not numba.__version__.startswith(CHECKED):
        return False
    if not hasattr(ir.Inst, "_numbas_rec_list_vars"):
        ir.Inst._numbas_rec_list_vars = ir.Inst._rec_list_vars
    ir.Inst._rec_list_vars = _rec_list_vars
    return True


SCALAR_OPERATORS = install_scalar_operators()
LIST_VARS = install_list_vars()
