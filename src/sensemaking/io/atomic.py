"""Write files whole or not at all: a failed run leaves no half-written output behind."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any


class PartFile:
    """A temporary file ``.<name>.<random>.part`` beside ``path`` (``visible``: ``<name>.part``
    when free), written in pieces and renamed over ``path`` by :meth:`commit`, or deleted by
    :meth:`discard` (nothing is left behind).

    ``handle`` is the open text (or, with ``"b"`` in ``mode``, binary) file.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        mode: str = "w",
        encoding: str | None = "utf-8",
        *,
        visible: bool = False,
    ):
        self.target = Path(path)
        self.target.parent.mkdir(parents=True, exist_ok=True)
        fd = -1
        if visible:  # ``<name>.part``, to be followed while written (unless another run has it)
            tmp = str(self.target.with_name(self.target.name + ".part"))
            try:
                fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600)
            except FileExistsError:
                fd = -1
        if fd < 0:
            fd, tmp = tempfile.mkstemp(
                prefix=f".{self.target.name}.", suffix=".part", dir=self.target.parent
            )
        self.part = Path(tmp)
        try:
            self.handle: IO[Any] = os.fdopen(fd, mode, encoding=None if "b" in mode else encoding)
        except BaseException:
            os.close(fd)
            self.part.unlink(missing_ok=True)
            raise
        self.done = False

    def commit(self) -> None:
        """Close and rename into place (with the usual file mode, not mkstemp's 0600)."""
        if self.done:
            return
        self.handle.close()
        umask = os.umask(0)
        os.umask(umask)
        try:
            os.chmod(self.part, 0o666 & ~umask)
            os.replace(self.part, self.target)
        except BaseException:
            self.part.unlink(missing_ok=True)
            raise
        finally:
            self.done = True

    def discard(self) -> None:
        """Close and delete the temporary file."""
        if self.done:
            return
        self.done = True
        try:
            self.handle.close()
        finally:
            self.part.unlink(missing_ok=True)


@contextmanager
def atomic_write(
    path: str | os.PathLike[str], mode: str = "w", encoding: str | None = "utf-8"
) -> Iterator[IO]:
    """Open a temporary file beside ``path``; on success rename it over ``path``, on error
    delete it."""
    part = PartFile(path, mode, encoding)
    try:
        yield part.handle
    except BaseException:
        part.discard()
        raise
    part.commit()
