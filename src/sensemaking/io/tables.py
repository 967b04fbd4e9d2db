"""Text tables: the parsing and checking that the MOTChallenge (:mod:`sensemaking.io.mot`) and
KITTI (:mod:`sensemaking.io.kitti`) readers share, and the lossless number formatting of the
writers.

Parsing is done with numpy for speed; only when that fails does a line-by-line pass run, to
find the first bad line and name it in the :class:`~sensemaking.errors.InputError`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import numpy as np

from sensemaking.errors import InputError
from sensemaking.io.text import read_input_text, refuse_stream

__all__ = [
    "PathLike",
    "Table",
    "parse_table",
    "parse_lines",
    "read_text",
    "first_line",
    "reading",
    "class_id_of",
    "num",
    "nums",
    "ints",
    "frame_order",
    "describe_counts",
]

PathLike = str | os.PathLike[str]


def class_id_of(name: str, path: PathLike | None = None, line: int | None = None) -> int:
    from sensemaking.classes import CLASS_IDS, class_id

    try:
        return class_id(name)
    except KeyError:
        known = ", ".join(sorted(CLASS_IDS))
        raise InputError(f"unknown class name {name!r} (known: {known})", path, line) from None


@contextmanager
def reading(path: PathLike) -> Iterator[Path]:
    """Turn the errors of reading ``path`` into InputError naming it."""
    p = Path(path)
    try:
        yield p
    except FileNotFoundError:
        raise InputError("no such file", p) from None
    except IsADirectoryError:
        raise InputError("is a directory, expected a file", p) from None
    except UnicodeDecodeError as exc:
        raise InputError(f"not a UTF-8 text file ({exc.reason} at byte {exc.start})", p) from None
    except OSError as exc:
        raise InputError(f"cannot read file: {exc.strerror or exc}", p) from None


def read_text(path: PathLike) -> str:
    """Whole file as text (UTF-8, byte-order mark skipped, universal newlines; a pipe or a
    device bounded as :func:`sensemaking.io.text.read_input_text` says)."""
    with reading(path) as p:
        return read_input_text(p, "utf-8-sig")


def first_line(path: PathLike) -> tuple[int, str] | None:
    """(1-based number, text) of the first non-blank line, or None for a blank file. A regular
    file only: its reader reads it again."""
    refuse_stream(path)
    with reading(path) as p, p.open(encoding="utf-8-sig") as handle:
        for number, line in enumerate(handle, start=1):
            if line.strip():
                return number, line.strip()
    return None


@dataclass
class Table:
    """A parsed text table.

    values: (N, C) float64, the file's columns (text columns are NaN).
    rows: (N,) int64, 1-based line number of each row.
    texts: column index -> the N raw strings of that text column.
    """

    path: PathLike
    values: np.ndarray
    rows: np.ndarray
    names: Sequence[str]
    texts: dict[int, list[str]] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.values.shape[0])

    @property
    def ncols(self) -> int:
        return int(self.values.shape[1])

    def fail(self, index: int, problem: str) -> NoReturn:
        """Raise InputError for row ``index`` (0-based into the table)."""
        raise InputError(problem, self.path, int(self.rows[index]))

    def name(self, col: int) -> str:
        return self.names[col] if col < len(self.names) else f"field {col + 1}"

    # checks --------------------------------------------------------------------------------
    def finite(self, cols: Sequence[int]) -> None:
        """Every value of these columns must be finite."""
        block = self.values[:, list(cols)]
        bad = ~np.isfinite(block)
        if bad.any():
            i = int(np.argmax(bad.any(axis=1)))
            j = int(np.argmax(bad[i]))
            self.fail(
                i, f"{self.name(cols[j])} must be a finite number, got {num(float(block[i, j]))}"
            )

    def integers(
        self,
        col: int,
        minimum: int | None = None,
        what: str = "",
        maximum: int | None = None,
        maximum_why: str = "",
    ) -> np.ndarray:
        """Column ``col`` as int64; every value must be a whole number in ``minimum..maximum``."""
        v = self.values[:, col]
        with np.errstate(invalid="ignore"):
            bad = ~np.isfinite(v) | (v != np.round(v)) | (np.abs(v) > 2.0**53)
        if bad.any():
            i = int(np.argmax(bad))
            self.fail(i, f"{self.name(col)} must be an integer, got {num(float(v[i]))}")
        out = v.astype(np.int64)
        if minimum is not None and len(out) and out.min() < minimum:
            i = int(np.argmax(out < minimum))
            self.fail(i, f"{self.name(col)} must be >= {minimum}{what}, got {out[i]}")
        if maximum is not None and len(out) and out.max() > maximum:
            i = int(np.argmax(out > maximum))
            self.fail(
                i,
                f"{self.name(col)} {out[i]} is beyond the plausibility bound {maximum}"
                f"{maximum_why}",
            )
        return out

    def sorted_frames(self, frames: np.ndarray) -> None:
        """Frames must not decrease from one line to the next (online input)."""
        if len(frames) > 1:
            down = np.diff(frames) < 0
            if down.any():
                i = int(np.argmax(down)) + 1
                self.fail(
                    i,
                    f"frame {frames[i]} comes after frame {frames[i - 1]}: "
                    "lines must be sorted by frame",
                )

    def positive_size(
        self,
        w: np.ndarray,
        h: np.ndarray,
        *,
        drop_zero: bool = False,
        logger: logging.Logger | None = None,
    ) -> np.ndarray:
        """Check box width ``w`` and height ``h`` (N,) in pixels are > 0.

        With ``drop_zero`` (detector output), boxes of exactly zero width or height are
        dropped with a warning rather than refused; returns the (N,) keep mask.
        """
        keep = np.ones(len(w), dtype=bool)
        bad = ~((w > 0) & (h > 0))
        if drop_zero:
            zero = ((w == 0) & (h >= 0)) | ((h == 0) & (w >= 0))
            bad &= ~zero
            keep = ~zero
        if bad.any():
            i = int(np.argmax(bad))
            self.fail(
                i,
                f"box width and height must be positive, got width {num(float(w[i]))} "
                f"and height {num(float(h[i]))}",
            )
        if not keep.all() and logger is not None:
            first = int(self.rows[int(np.argmax(~keep))])
            logger.warning(
                "%s: dropped %d detection(s) of zero width or height (first on line %d)",
                self.path,
                int((~keep).sum()),
                first,
            )
        return keep


def describe_counts(counts: Collection[int]) -> str:
    c = sorted(counts)
    if len(c) == 1:
        return str(c[0])
    if c == list(range(c[0], c[-1] + 1)) and len(c) > 2:
        return f"{c[0]} to {c[-1]}"
    return ", ".join(map(str, c[:-1])) + f" or {c[-1]}"


def parse_table(
    path: PathLike,
    *,
    sep: str | None,
    names: Mapping[int, Sequence[str]],
    text_cols: Collection[int] = (),
) -> Table:
    """Parse a delimited numeric text file (``sep=None``: runs of whitespace).

    ``names`` maps each allowed number of fields to the column names (for messages). Blank lines
    are skipped (line numbers stay right). Every line must have the same number of fields; fields
    not in ``text_cols`` must be numbers. An empty file gives a table of shape (0, 0).
    """
    lines = read_text(path).split("\n")
    while lines and not lines[-1].strip():
        lines.pop()
    blank = [i for i, line in enumerate(lines) if not line.strip()]
    if blank:
        keep = np.ones(len(lines), dtype=bool)
        keep[blank] = False
        rows = np.flatnonzero(keep).astype(np.int64) + 1
        body = [lines[i] for i in np.flatnonzero(keep)]
    else:
        rows = np.arange(1, len(lines) + 1, dtype=np.int64)
        body = lines
    return parse_lines(path, body, rows, sep=sep, names=names, text_cols=text_cols)


def parse_lines(
    path: PathLike,
    body: list[str],
    rows: np.ndarray,
    *,
    sep: str | None,
    names: Mapping[int, Sequence[str]],
    text_cols: Collection[int] = (),
) -> Table:
    """:func:`parse_table` of some non-blank lines of ``path`` (``rows``: their 1-based numbers),
    e.g. one chunk of a file read piece by piece (:mod:`sensemaking.io.stream`)."""
    counts = sorted(names)
    if not body:
        return Table(path, np.zeros((0, 0)), rows, ())

    kind = "comma-separated" if sep == "," else "space-separated"
    parts: list[list[str]] | None = None
    if sep is None or text_cols:
        parts = [line.split(sep) for line in body]
        nfields = [len(p) for p in parts]
    else:
        nfields = [line.count(sep) + 1 for line in body]
    ncols = nfields[0]
    if ncols not in counts:
        raise InputError(
            f"expected {describe_counts(counts)} {kind} fields, got {ncols}", path, int(rows[0])
        )
    if nfields.count(ncols) != len(nfields):
        i = next(i for i, n in enumerate(nfields) if n != ncols)
        raise InputError(f"expected {ncols} {kind} fields, got {nfields[i]}", path, int(rows[i]))

    columns = names[ncols]
    numeric = [c for c in range(ncols) if c not in text_cols]
    try:
        parsed = np.loadtxt(
            body,
            dtype=np.float64,
            delimiter=sep,
            comments=None,
            ndmin=2,
            usecols=numeric if text_cols else None,
        )
        if parsed.shape != (len(body), len(numeric)):
            raise ValueError("shape")  # pragma: no cover - defensive
    except ValueError:
        parsed = parse_slow(path, body, rows, sep, numeric, columns)
    if text_cols:
        values = np.full((len(body), ncols), np.nan)
        values[:, numeric] = parsed
        assert parts is not None
        texts = {c: [p[c].strip() for p in parts] for c in text_cols}
    else:
        values, texts = parsed, {}
    return Table(path, values, rows, columns, texts)


def parse_slow(
    path: PathLike,
    body: list[str],
    rows: np.ndarray,
    sep: str | None,
    numeric: list[int],
    names: Sequence[str],
) -> np.ndarray:
    """Line-by-line parse: raises InputError at the first field that is not a number."""
    out = np.empty((len(body), len(numeric)))
    for i, line in enumerate(body):
        fields = line.split(sep)
        for k, c in enumerate(numeric):
            text = fields[c].strip()
            try:
                out[i, k] = float(text)
            except ValueError:
                what = names[c] if c < len(names) else "value"
                raise InputError(
                    f"field {c + 1} ({what}) is not a number: {text!r}", path, int(rows[i])
                ) from None
    return out


def num(x: float) -> str:
    """Shortest text that parses back to exactly ``x`` (``repr``), ``.0`` dropped for whole
    numbers."""
    r = repr(float(x))
    return r[:-2] if r.endswith(".0") else r


def nums(a: np.ndarray) -> list[str]:
    """:func:`num` of every element of a 1-D float array (one ``repr`` of the whole list: fast)."""
    values = np.asarray(a, dtype=np.float64).tolist()
    if not values:
        return []
    return [t[:-2] if t[-2:] == ".0" else t for t in repr(values)[1:-1].split(", ")]


def ints(a: np.ndarray) -> list[str]:
    """Decimal text of every element of a 1-D integer array."""
    values = np.asarray(a, dtype=np.int64).tolist()
    return repr(values)[1:-1].split(", ") if values else []


def frame_order(frames: np.ndarray) -> np.ndarray:
    """Stable permutation sorting by frame (identity when already sorted)."""
    return np.argsort(frames, kind="stable")
