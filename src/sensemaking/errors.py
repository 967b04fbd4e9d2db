"""Errors raised for bad user input; the CLI turns them into one clear line and exit status 2."""

from __future__ import annotations

from os import PathLike

#: the problem of a JSON input nested deeper than Python's reader goes (RecursionError)
TOO_DEEP = "not readable JSON: nested too deeply"


class SensemakingError(Exception):
    """Base class of every error this package raises on purpose."""


class InputError(SensemakingError, ValueError):
    """Bad input data: names the file, the 1-based line (when known) and the problem."""

    def __init__(
        self, problem: str, path: str | PathLike[str] | None = None, line: int | None = None
    ):
        self.problem = problem
        self.path = None if path is None else str(path)
        self.line = line
        where = ""
        if self.path is not None:
            where = self.path if line is None else f"{self.path}:{line}"
            where += ": "
        elif line is not None:
            where = f"line {line}: "
        super().__init__(f"{where}{problem}")


class FrameLimitError(InputError):
    """A frame of the input past a per-frame limit (detections, live tracks): the input's
    fault, so a caller that knows the input file names it."""


class ProgramError(InputError):
    """A user's program (``--encoding``, ``--rules``, ``--confidence``) failed on a frame's
    facts (grounding, no answer set, the atom limit): the caller that knows the program's files
    names them."""


class MissingExtraError(SensemakingError, ImportError):
    """An optional dependency is missing; names the extra that provides it."""

    def __init__(self, module: str, extra: str):
        super().__init__(
            f"this feature needs the '{module}' package: install it with "
            f"pip install 'sensemaking[{extra}]'"
        )


def require(module: str, extra: str):
    """Import an optional module, or raise :class:`MissingExtraError` naming the extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingExtraError(module, extra) from exc
