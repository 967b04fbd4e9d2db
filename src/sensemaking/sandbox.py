"""The limits every ASP program from outside the package runs under: ``ask``'s queries
(untrusted) and the user's own encodings (``track --rules / --encoding / --situations``).

Two steps, each one call for its caller:

* :func:`check_program` refuses text before clingo sees it. clingo's parser itself opens the
  file of an ``#include`` while it parses (even after a syntax error it recovers from), so the
  check cannot be "parse, then walk the tree": it is on the raw text. Every ``#`` must be
  followed by an allowed directive name -- inside comments and strings too, so that no
  disagreement between this check and clingo's lexer about where a string or comment ends can
  hide a directive. Then the text is parsed by clingo (now safe) and any syntax error refuses it
  with ``WHERE:LINE:COLUMN: message`` on one line.
* :func:`run_limited` runs grounding and solving in a forked child with a time limit, a memory
  limit (``RLIMIT_AS``: the current size plus ``max_memory_mb``) and an atom limit (checked by
  the work itself once grounding is done, :func:`check_atoms`). Ctrl-C and SIGTERM kill the
  child at once; past a limit the child is killed and the error says which limit.
"""

from __future__ import annotations

import os
import re
import signal
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from sensemaking.errors import InputError, SensemakingError

__all__ = [
    "DEFAULT_TIMEOUT_S",
    "DEFAULT_MAX_ATOMS",
    "DEFAULT_MAX_MEMORY_MB",
    "QUERY_DIRECTIVES",
    "Limits",
    "LimitError",
    "check_program",
    "check_atoms",
    "run_limited",
]

#: limits of an ASP program from outside: wall-clock seconds for grounding + solving, ground
#: atoms, memory beyond what the process already uses (MB)
DEFAULT_TIMEOUT_S = 60.0
DEFAULT_MAX_ATOMS = 5_000_000
DEFAULT_MAX_MEMORY_MB = 2048

#: the directives an ``ask`` query may use (everything else is refused)
QUERY_DIRECTIVES = frozenset(
    {
        "show",
        "count",
        "sum",
        "sum+",
        "min",
        "max",
        "minimize",
        "maximize",
        "minimise",
        "maximise",
        "inf",
        "sup",
        "true",
        "false",
    }
)
#: the directives a user's encoding may not use: reading files, running code
ENCODING_FORBIDDEN = frozenset({"include", "script"})

_HASH = re.compile(r"#([A-Za-z_]*\+?)")
_LOC = re.compile(r"<string>:(\d+):(\d+)(?:-\d+(?::\d+)?)?:\s*")


@dataclass(frozen=True)
class Limits:
    """Time (s), ground atoms and memory (MB) of one program run; None: no limit."""

    timeout_s: float | None = DEFAULT_TIMEOUT_S
    max_atoms: int | None = DEFAULT_MAX_ATOMS
    max_memory_mb: int | None = DEFAULT_MAX_MEMORY_MB

    def __post_init__(self) -> None:
        for name in ("timeout_s", "max_atoms", "max_memory_mb"):
            v = getattr(self, name)
            if v is not None and not (v > 0 and v == v and v != float("inf")):
                raise InputError(f"{name} must be a positive number or None, got {v!r}")


class LimitError(SensemakingError):
    """A program went past one of its :class:`Limits` (the message names which)."""


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def check_program(
    text: str,
    where: str,
    *,
    allowed: frozenset[str] | None = None,
    forbidden: frozenset[str] = ENCODING_FORBIDDEN,
    allow_at: bool = True,
    error: Callable[[str, int | None, int | None], Exception] | None = None,
) -> list[Any]:
    """Refuse ``text`` if it reaches outside (see the module docstring), else parse it.

    Args:
        text: the program.
        where: its name in messages (a path, or ``query``).
        allowed: when given, the only directive names allowed (``QUERY_DIRECTIVES``).
        forbidden: directive names refused (used when ``allowed`` is None).
        allow_at: False refuses ``@``-terms (calls into script functions).
        error: builds the exception from (message, line, column); default InputError.

    Returns:
        clingo's parsed statements.
    """
    from clingo import ast as clingo_ast

    def fail(msg: str, line: int | None = None, col: int | None = None) -> Exception:
        if error is not None:
            return error(msg, line, col)
        return InputError(msg)

    for m in _HASH.finditer(text):
        name = m.group(1).lower()
        bad = (name not in allowed) if allowed is not None else name in forbidden
        if bad:
            at_line = _line_of(text, m.start())
            what = f"#{m.group(1)}" if name else "a '#' without a directive name"
            scope = "a query" if allowed is not None else "a user encoding"
            hint = (
                " (allowed: rules, constraints, aggregates, #show, #minimize/#maximize)"
                if allowed is not None
                else " (it would read files or run code)"
            )
            raise fail(
                f"{where}:{at_line}: {what} is not allowed in {scope}{hint}; this holds in "
                "comments and strings too",
                at_line,
                None,
            )
    at = text.find("@")
    if not allow_at and at >= 0:
        at_line = _line_of(text, at)
        raise fail(
            f"{where}:{at_line}: @-terms (script functions) are not allowed, in comments and "
            "strings too",
            at_line,
            None,
        )
    messages: list[str] = []
    stmts: list[Any] = []
    try:
        clingo_ast.parse_string(
            text, stmts.append, logger=lambda _c, msg: messages.append(msg), message_limit=5
        )
    except RuntimeError:
        first = " ".join((messages[0] if messages else "syntax error").split())
        loc = _LOC.search(first)
        line: int | None = None
        col: int | None = None
        if loc:
            line, col = int(loc.group(1)), int(loc.group(2))
            first = _LOC.sub("", first, count=1)
        first = first.removeprefix("error: ")
        raise fail(
            f"{where}:{line}:{col}: {first}" if line else f"{where}: {first}", line, col
        ) from None
    return stmts


def check_atoms(n_atoms: int, max_atoms: int | None, what: str) -> None:
    """Raise :class:`LimitError` when a ground program has more atoms than ``max_atoms``."""
    if max_atoms is not None and n_atoms > max_atoms:
        raise LimitError(
            f"{what} grounds to {n_atoms} atoms, more than the limit of {max_atoms} (--max-atoms)"
        )


def _child(
    conn: Any, work: Callable[[Callable[[Any], None]], Any], max_memory_mb: int | None
) -> None:  # pragma: no cover - runs in the child
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C and stops the child
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        if max_memory_mb is not None:
            import resource

            with open("/proc/self/statm") as fh:
                now = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
            cap = now + int(max_memory_mb) * 2**20
            resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
        result = work(lambda item: conn.send(("item", item)))
        conn.send(("done", result))
    except MemoryError:
        conn.send(("memory",))
    except SensemakingError as exc:
        try:
            conn.send(("raise", exc))
        except Exception:  # an exception that does not pickle: its message
            conn.send(("fail", str(exc)))
    except RuntimeError as exc:
        text = " ".join(str(exc).split())
        conn.send(
            ("memory",)
            if "bad_alloc" in text or "memory" in text.lower()
            else ("fail", f"clingo failed: {text}")
        )
    except BaseException as exc:
        conn.send(("fail", f"{type(exc).__name__}: {' '.join(str(exc).split())}"))
    finally:
        conn.close()
        os._exit(0)


def run_limited(
    work: Callable[[Callable[[Any], None]], Any],
    limits: Limits,
    *,
    what: str = "the program",
    on_item: Callable[[Any], None] | None = None,
    fail: Callable[[str], Exception] = LimitError,
) -> Any:
    """``work(send)`` in a forked child under ``limits``; returns what it returns (picklable).

    ``work`` may call ``send(item)`` to pass picklable items on as they come (``on_item`` gets
    them in the parent) and should call :func:`check_atoms` after grounding. A
    :class:`~sensemaking.errors.SensemakingError` it raises is raised here; a time or memory
    limit raises ``fail(message)`` naming the limit; Ctrl-C (KeyboardInterrupt) kills the child.
    Without ``fork`` (not Linux) the work runs here, with the atom limit only.
    """
    import multiprocessing

    def emit(item: Any) -> None:
        if on_item is not None:
            on_item(item)

    if "fork" not in multiprocessing.get_all_start_methods():  # pragma: no cover - not Linux
        return work(emit)
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, work, limits.max_memory_mb), daemon=True)
    proc.start()
    send.close()
    timeout = limits.timeout_s
    deadline = None if timeout is None else time.monotonic() + timeout
    memory = (
        f"{what} needs more memory than the limit of {limits.max_memory_mb} MB "
        "(--max-memory); narrow it (fewer variables joined, smaller ranges)"
    )
    try:
        while True:
            wait = 0.5 if deadline is None else min(0.5, deadline - time.monotonic())
            if wait <= 0:
                raise fail(f"{what} took longer than the time limit of {timeout:g} s (--timeout)")
            if not receive.poll(wait):
                if not proc.is_alive() and not receive.poll(0):
                    raise fail(memory)
                continue
            try:
                msg = receive.recv()
            except EOFError:
                raise fail(memory) from None
            if msg[0] == "item":
                emit(msg[1])
            elif msg[0] == "done":
                return msg[1]
            elif msg[0] == "memory":
                raise fail(memory)
            elif msg[0] == "raise":
                raise msg[1]
            else:
                raise fail(msg[1])
    finally:
        receive.close()
        if proc.is_alive():
            proc.kill()
        proc.join()


def first_messages(messages: Iterable[str], default: str) -> str:
    """clingo's first message on one line (``<string>`` locations dropped)."""
    for m in messages:
        return " ".join(m.split())
    return default
