"""Write files whole or not at all: a failed run leaves no half-written output behind.

The one place outputs are opened (issue 24): a regular file (or a new name) is written to a
temporary file beside it and renamed over it; a symlink is followed (the link stays, its target
is replaced); anything else that exists -- a device such as ``/dev/stdout`` or ``/dev/null``, a
FIFO, a socket -- is written through, never replaced. A write error (a full disk, a file size
limit) names the output and leaves no temporary file behind.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any, cast


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
        self.done = False
        #: written straight into the target (a device, a FIFO: nothing to rename)
        self.through = False
        try:
            st = os.stat(self.target)  # what a symlink names
        except FileNotFoundError:
            st = None
        except OSError as exc:  # a symlink loop, a name too long ...
            raise _named(exc, self.target) from None
        if st is not None and stat.S_ISREG(st.st_mode) and os.path.islink(self.target):
            self.target = Path(os.path.realpath(self.target))  # replace its target, keep the link
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError(errno.EISDIR, "is a directory", str(self.target))
        if st is not None and not stat.S_ISREG(st.st_mode):
            self.part = self.target
            self.through = True
            try:
                raw = open(  # noqa: SIM115 - closed by commit / discard
                    self.target, mode, encoding=None if "b" in mode else encoding
                )
            except OSError as exc:
                raise _named(exc, self.target) from None
            self.handle: IO[Any] = cast(IO[Any], NamedIO(raw, self.target))
            return
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
            raw = os.fdopen(fd, mode, encoding=None if "b" in mode else encoding)
        except BaseException:
            os.close(fd)
            self.part.unlink(missing_ok=True)
            raise
        self.handle = cast(IO[Any], NamedIO(raw, self.target))

    def commit(self) -> None:
        """Close and rename into place (with the usual file mode, not mkstemp's 0600); a file
        written through is only closed. A failed close (the last write) discards."""
        if self.done:
            return
        try:
            self.handle.close()
        except BaseException:
            self.discard()
            raise
        if self.through:
            self.done = True
            return
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
        except OSError:
            pass  # the write that failed was reported already
        finally:
            if not self.through:
                self.part.unlink(missing_ok=True)


def _named(exc: OSError, path: Path) -> OSError:
    """``exc`` with the output's name (a write error otherwise names no file)."""
    return type(exc)(exc.errno, exc.strerror or str(exc), str(path))


class NamedIO:
    """A file whose write errors name the output (``[Errno 27] File too large: 'out.txt'``)."""

    def __init__(self, raw: IO[Any], path: Path):
        self._raw = raw
        self._path = path

    def write(self, data: Any) -> int:
        try:
            return self._raw.write(data)
        except OSError as exc:
            raise _named(exc, self._path) from None

    def writelines(self, lines: Any) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        try:
            self._raw.flush()
        except OSError as exc:
            raise _named(exc, self._path) from None

    def close(self) -> None:
        try:
            self._raw.close()
        except OSError as exc:
            raise _named(exc, self._path) from None

    def __getattr__(self, name: str) -> Any:
        return getattr(self._raw, name)

    def __iter__(self) -> Any:  # dunders are not found through __getattr__
        return iter(self._raw)

    def __enter__(self) -> NamedIO:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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
