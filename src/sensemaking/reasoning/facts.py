"""ASP facts as clingo symbols, and answers read back as Python values.

Facts are written as plain tuples ``(name, arg, ...)`` -- cheap to build, hash and compare, so a
caller can key a cache on them -- and turned into clingo symbols only when clingo needs them:
an ``int`` is a number, a ``str`` a constant (an ASP identifier such as ``visible``), an
:class:`AspString` a quoted string, a tuple a function term ``name(args...)``.
"""

from __future__ import annotations

from typing import Any

import clingo

__all__ = ["AspString", "Fact", "symbol", "value"]

#: one fact or term: ``(name, arg, ...)``
Fact = tuple[Any, ...]


class AspString(str):
    """A string given to clingo as a quoted ASP string (``"lane 1"``), not a constant."""

    __slots__ = ()


def symbol(term: Any) -> clingo.Symbol:
    """The clingo symbol of an int, a constant (str), an :class:`AspString` or a tuple
    ``(name, arg, ...)`` (a function term; ``("", a, b)`` is the tuple ``(a,b)``)."""
    if isinstance(term, tuple):
        return clingo.Function(term[0], [symbol(a) for a in term[1:]])
    if isinstance(term, AspString):
        return clingo.String(term)
    if isinstance(term, str):
        return clingo.Function(term)
    if isinstance(term, int) and not isinstance(term, bool):
        return clingo.Number(term)
    raise TypeError(f"no ASP term for {term!r} ({type(term).__name__})")


def value(sym: clingo.Symbol) -> Any:
    """A number as int, a string as str, a constant by its name, any other term as its text."""
    if sym.type == clingo.SymbolType.Number:
        return sym.number
    if sym.type == clingo.SymbolType.String:
        return sym.string
    if sym.type == clingo.SymbolType.Function and not sym.arguments and sym.name:
        return sym.name
    return str(sym)
