"""Reading a text input whole, with bounds that hold for any file a user names.

A regular file is read as :meth:`pathlib.Path.read_text` reads it: its size is its content. A
pipe or a device (a FIFO, ``/dev/stdin``, ``/dev/zero``, a process substitution) has no size: it
is read in chunks, refused at its first NUL byte (no text input has one, and ``/dev/zero`` is
nothing else) and past :data:`MAX_STREAM_TEXT_BYTES`. JSON texts go through :func:`load_json`,
which refuses an integer past the float range (more than 308 digits; past 4300 Python's reader
fails with a bare ValueError) as a decode error at its line.
"""

from __future__ import annotations

import io
import json
import os
import re
import stat
from typing import Any, BinaryIO

from sensemaking.errors import InputError

__all__ = ["MAX_STREAM_TEXT_BYTES", "read_input_text", "refuse_stream", "refuse_nul", "load_json"]

#: bytes a text input read whole may have when it is a pipe or a device, not a regular file
MAX_STREAM_TEXT_BYTES = 2**30
#: digits of the longest integer a JSON input may hold (every float is below 1e309)
MAX_INT_DIGITS = 308
_LONG_INTEGER = re.compile(rf"(?<![\d.eE])\d{{{MAX_INT_DIGITS + 1},}}")
_CHUNK = 2**20


def read_input_text(path: str | os.PathLike[str], encoding: str = "utf-8") -> str:
    """The text of ``path`` (universal newlines, as ``Path.read_text(encoding)``).

    Raises:
        OSError, UnicodeDecodeError: as ``Path.read_text`` (no such file, a directory, ...).
        InputError: a pipe or device that gives a NUL byte or more than
            :data:`MAX_STREAM_TEXT_BYTES` bytes.
    """
    with open(path, "rb") as fh:  # a FIFO: waits for its writer, as any reader would
        if stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
            data = fh.read()
        else:
            data = _read_stream(fh, path)
    return io.TextIOWrapper(io.BytesIO(data), encoding=encoding).read()


def refuse_stream(path: str | os.PathLike[str]) -> None:
    """InputError if ``path`` is a pipe or a device: a reader that reads a file twice (its first
    line for its kind, then the whole) or line by line needs a regular file. A missing file or a
    directory is left to the reader's own message."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise InputError("not a regular file (a pipe or a device): give a file", path)


def refuse_nul(chunk: bytes, offset: int, path: str | os.PathLike[str]) -> None:
    """InputError if ``chunk`` (the bytes of a text stream from byte ``offset`` on) has a NUL
    byte: no text input has one, and ``/dev/zero`` nothing else."""
    nul = chunk.find(b"\0")
    if nul >= 0:
        raise InputError(
            f"a NUL byte at byte {offset + nul}: not a text file (a device or a binary stream?)",
            path,
        )


def _read_stream(fh: BinaryIO, path: str | os.PathLike[str]) -> bytes:
    out = bytearray()
    while chunk := fh.read(_CHUNK):
        refuse_nul(chunk, len(out), path)
        out += chunk
        if len(out) > MAX_STREAM_TEXT_BYTES:
            raise InputError(
                f"more than {MAX_STREAM_TEXT_BYTES} bytes from a pipe or device: give a file",
                path,
            )
    return bytes(out)


class _LongInteger(Exception):
    """An integer literal past :data:`MAX_INT_DIGITS` (raised inside the JSON scanner)."""


def _int(literal: str) -> int:
    if len(literal) - literal.startswith("-") > MAX_INT_DIGITS:
        raise _LongInteger
    return int(literal)


def load_json(text: str) -> Any:
    """``json.loads(text)``, except that an integer of more than :data:`MAX_INT_DIGITS` digits
    is a :class:`json.JSONDecodeError` at its position, like every other fault of the text (no
    float holds it, and past 4300 digits Python refuses to convert it at all)."""
    try:
        return json.loads(text, parse_int=_int)
    except _LongInteger:
        found = _LONG_INTEGER.search(text)
        raise json.JSONDecodeError(
            f"an integer of more than {MAX_INT_DIGITS} digits", text, found.start() if found else 0
        ) from None
