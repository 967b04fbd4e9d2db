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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from sensemaking import asp
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
    "probe_program",
    "relocate",
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
        if allowed is None:
            first = "the encoding does not parse: " + first
        raise fail(
            f"{where}:{line}:{col}: {first}" if line else f"{where}: {first}", line, col
        ) from None
    return stmts


#: size of a program file read (bytes): an encoding is text, not data
MAX_PROGRAM_BYTES = 16 * 2**20


def read_program_file(path: str | os.PathLike[str]) -> str:
    """The text of a user's ``.lp`` file: a regular file of at most ``MAX_PROGRAM_BYTES``
    (a FIFO or a device would block or never end). Raises OSError / UnicodeDecodeError as
    reading does, InputError for the rest."""
    import stat

    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise InputError("not a regular file (an encoding is read whole before any work)", path)
    if st.st_size > MAX_PROGRAM_BYTES:
        raise InputError(
            f"{st.st_size} bytes, more than an encoding may have ({MAX_PROGRAM_BYTES})", path
        )
    with open(path, encoding="utf-8") as fh:
        return fh.read(MAX_PROGRAM_BYTES + 1)


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
            if cap < 2**62:  # past it no machine's memory: no limit (setrlimit overflows)
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


_AT = re.compile(r"<(?:string|block)>:(\d+):(\d+)(?:-(\d+:)?\d+)?")


def relocate(message: str, parts: Sequence[tuple[str, str]]) -> str:
    """``message`` with ``<string>:LINE:COL`` of a program made of ``parts`` (name, text; joined
    by newlines) written ``name:line:col`` of the part that holds the line; on one line."""
    starts: list[tuple[int, str]] = []
    line = 1
    for name, text in parts:
        starts.append((line, name))
        line += text.count("\n") + 1

    def sub(m: re.Match[str]) -> str:
        at = int(m.group(1))
        first, name = max((s for s in starts if s[0] <= at), default=(1, "program"))
        return f"{name}:{at - first + 1}:{m.group(2)}"

    return " ".join(_AT.sub(sub, message).split())


def probe_program(
    build: Callable[[Any], None],
    args: Sequence[str],
    *,
    where: str,
    parts: Sequence[tuple[str, Sequence[Any]]] = (("base", ()),),
    limits: Limits | None = None,
    locate: Callable[[str], str] = lambda m: " ".join(m.split()),
) -> None:
    """Ground and solve a user's program once, without facts, in a limited child
    (:func:`run_limited`), before any work: a syntax or grounding error (unsafe variables, an
    unknown ``@``-function ...), a program past a limit (``p(1..100000000).``) or one without
    an answer set is an :class:`~sensemaking.errors.InputError` naming ``where``, on one line.

    ``build(ctl)`` adds the program to a fresh ``clingo.Control(args)``; ``parts`` are grounded;
    ``locate`` rewrites clingo's message (locations in the user's files).
    """
    lim = limits if limits is not None else Limits()

    def work(_send: Callable[[Any], None]) -> bool:
        messages: list[str] = []
        ctl = asp.control(
            [*args, *asp.limits(max_models=1)],
            logger=lambda _c, m: messages.append(m),
            message_limit=5,
        )
        try:
            build(ctl)
            ctl.ground(list(parts))
        except RuntimeError as exc:
            first = ([m for m in messages if "error" in m] or messages or [str(exc)])[0]
            located = locate(first).replace(": error: ", ": ")
            # a message located in the user's file names it already
            named = located.split(":", 1)[0] in where.split(", ")
            raise InputError(located if named else f"{where}: {located}") from None
        check_atoms(len(ctl.symbolic_atoms), lim.max_atoms, where)
        return bool(ctl.solve().satisfiable)

    satisfiable = run_limited(work, lim, what=where, fail=lambda m: InputError(m))
    if not satisfiable:
        raise InputError(
            f"{where}: the program has no answer set even without detections (UNSATISFIABLE): "
            "a constraint that always fires?"
        )


def check_user_encoding(
    program: str,
    options: Sequence[str],
    parts: Sequence[tuple[str, str]],
    limits: Limits | None = None,
) -> None:
    """:func:`probe_program` of a text ``program`` made of ``parts`` (name, text; joined by
    newlines), e.g. the tracker's encoding plus ``--rules``; messages name the part's file."""
    names = [n for n, _ in parts if n != "tracking.lp"] or [n for n, _ in parts]
    probe_program(
        lambda ctl: ctl.add("base", [], program),
        options,
        where=", ".join(names),
        limits=limits,
        locate=lambda m: relocate(m, parts),
    )
