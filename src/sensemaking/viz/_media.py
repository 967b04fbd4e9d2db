"""Frame sources (image folders, videos) and streaming writers (GIF, mp4, PNG folders).

Writers take Pillow images one at a time and keep O(1) frames in memory; each writes to a
temporary name beside the output and renames it into place only when every frame was written.
"""

from __future__ import annotations

import io
import os
import shutil
import struct
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from sensemaking.errors import InputError, require
from sensemaking.io.media import (  # noqa: F401  (re-exported: frame sources live in io)
    IMAGE_SUFFIXES,
    VIDEO_SUFFIXES,
    ImageFolder,
    VideoFrames,
    iter_video_frames,
    list_images,
)

__all__ = [
    "IMAGE_SUFFIXES",
    "VIDEO_SUFFIXES",
    "list_images",
    "ImageFolder",
    "VideoFrames",
    "open_writer",
    "output_kind",
    "GifWriter",
    "VideoWriter",
    "PngFolderWriter",
]


# writers ----------------------------------------------------------------------------------------
def output_kind(path: str | os.PathLike[str]) -> str:
    """``"gif"``, ``"video"`` or ``"png"`` (a folder of PNGs) from the output path."""
    text = os.fspath(path)
    p = Path(text)
    suffix = p.suffix.lower()
    if text.endswith(("/", os.sep)) or p.is_dir() or not suffix:
        return "png"
    if suffix == ".gif":
        return "gif"
    if suffix in VIDEO_SUFFIXES:
        return "video"
    raise InputError(
        f"unknown output type {suffix!r}: use .gif, one of {', '.join(sorted(VIDEO_SUFFIXES))}, "
        "or a folder (PNG frames)",
        p,
    )


def open_writer(path: str | os.PathLike[str], size: tuple[int, int], fps: float) -> Any:
    """The writer for ``path`` (see :func:`output_kind`); a context manager with
    ``write(image, frame)``."""
    kind = output_kind(path)
    if kind == "gif":
        return GifWriter(path, size, fps)
    if kind == "video":
        return VideoWriter(path, size, fps)
    return PngFolderWriter(path, size, fps)


class _Writer:
    def __init__(self, path: str | os.PathLike[str], size: tuple[int, int], fps: float):
        self.path = Path(path)
        self.size = (int(size[0]), int(size[1]))
        self.fps = float(fps)
        self.count = 0
        if self.fps <= 0:
            raise InputError(f"fps must be positive, got {fps}")

    def __enter__(self) -> _Writer:
        return self

    def __exit__(self, exc_type: Any, *rest: Any) -> None:
        if exc_type is None:
            try:
                self.close()
            except BaseException:  # e.g. the rename into place failed: no .part is left
                self.abort()
                raise
        else:
            self.abort()

    def write(self, image: Any, frame: int) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def close(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def abort(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError


def usual_mode(path: Path) -> None:
    """Give ``path`` the permissions a plain ``open`` would (mkstemp / mkdtemp make them
    0600 / 0700)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, (0o777 if path.is_dir() else 0o666) & ~umask)


def _publish(tmp: Path, path: Path) -> None:
    """Rename ``tmp`` over ``path`` with the usual permissions."""
    usual_mode(tmp)
    os.replace(tmp, path)


def _temp_beside(path: Path, suffix: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".part{suffix}", dir=path.parent)
    os.close(fd)
    return Path(tmp)


class GifWriter(_Writer):
    """Animated GIF, streamed: each frame is LZW-encoded by Pillow alone and appended.

    Palette ("P") frames are written as they are; RGB frames are quantised to 256 colours. A
    frame whose colour table differs from the first frame's carries a local colour table. A
    palette frame with the same palette as the frame before is written as the rectangle that
    changed only (drawn over the previous frame), which makes encoding faster and files smaller.
    """

    def __init__(
        self, path: str | os.PathLike[str], size: tuple[int, int], fps: float, loop: int = 0
    ):
        super().__init__(path, size, fps)
        self.loop = loop
        self._tmp = _temp_beside(self.path, ".gif")
        self._fh: Any = open(self._tmp, "wb")
        self._global_table: bytes | None = None
        self._prev: Any = None  # (indices (H, W) uint8, palette) of the previous palette frame

    def _delay(self, k: int) -> int:
        """Centiseconds of frame ``k``, rounded so the total duration does not drift."""
        return max(round((k + 1) * 100 / self.fps) - round(k * 100 / self.fps), 1)

    def write(self, image: Any, frame: int) -> None:
        if image.size != self.size:
            raise ValueError(f"frame size {image.size} differs from {self.size}")
        left = top = 0
        if image.mode != "P":
            pil = require("PIL.Image", "viz")
            image = image.convert("RGB").quantize(
                256, method=pil.Quantize.FASTOCTREE, dither=pil.Dither.NONE
            )
            self._prev = None
        else:
            import numpy as np

            pixels, pal = np.asarray(image), image.getpalette()
            prev, self._prev = self._prev, (pixels, pal)
            if prev is not None and prev[1] == pal and self._global_table is not None:
                changed = pixels != prev[0]
                rows, cols = (
                    np.flatnonzero(changed.any(axis=1)),
                    np.flatnonzero(changed.any(axis=0)),
                )
                if rows.size:
                    top, left = int(rows[0]), int(cols[0])
                    image = image.crop((left, top, int(cols[-1]) + 1, int(rows[-1]) + 1))
                else:
                    image = image.crop((0, 0, 1, 1))  # nothing changed: one unchanged pixel
        buf = io.BytesIO()
        image.save(buf, "GIF", optimize=False)
        lsd, table, descriptor, local, data = _parse_single_gif(buf.getvalue())
        descriptor = descriptor[:1] + struct.pack("<HH", left, top) + descriptor[5:]
        fh = self._fh
        if self._global_table is None:
            self._global_table = table
            fh.write(b"GIF89a" + lsd + table)
            # NETSCAPE2.0 application extension: loop count
            fh.write(b"\x21\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", self.loop) + b"\x00")
        # graphic control extension: no disposal, delay, no transparency
        fh.write(b"\x21\xf9\x04\x04" + struct.pack("<H", self._delay(self.count)) + b"\x00\x00")
        if local is None and table != self._global_table:
            local = table
        if local is not None:
            bits = max((len(local) // 3 - 1).bit_length() - 1, 0)
            packed = (descriptor[9] & 0x60) | 0x80 | bits
            fh.write(descriptor[:9] + bytes([packed]) + local)
        else:
            fh.write(descriptor[:9] + bytes([descriptor[9] & 0x60]))
        fh.write(data)
        self.count += 1

    def close(self) -> None:
        self._fh.write(b"\x3b")
        self._fh.close()
        if self.count == 0:
            self.abort()
            raise InputError("nothing to write: no frames", self.path)
        _publish(self._tmp, self.path)

    def abort(self) -> None:
        self._fh.close()
        self._tmp.unlink(missing_ok=True)


def _parse_single_gif(blob: bytes) -> tuple[bytes, bytes, bytes, bytes | None, bytes]:
    """Split a one-frame GIF into (screen descriptor, global table, image descriptor, local table,
    data).

    ``image descriptor`` is the 0x2C separator and the 9 bytes after it (10 bytes);
    ``data`` is the LZW minimum code size plus every sub-block and the terminator.
    """
    if blob[:3] != b"GIF":
        raise ValueError("not a GIF")
    lsd = blob[6:13]
    pos = 13
    table = b""
    if lsd[4] & 0x80:
        n = 3 * (2 ** ((lsd[4] & 7) + 1))
        table = blob[pos : pos + n]
        pos += n
    while pos < len(blob):
        tag = blob[pos]
        if tag == 0x21:  # extension: label, then sub-blocks
            pos += 2
            while blob[pos]:
                pos += blob[pos] + 1
            pos += 1
        elif tag == 0x2C:
            descriptor = blob[pos : pos + 10]
            pos += 10
            local = None
            if descriptor[9] & 0x80:
                n = 3 * (2 ** ((descriptor[9] & 7) + 1))
                local = blob[pos : pos + n]
                pos += n
            start = pos
            pos += 1  # LZW minimum code size
            while blob[pos]:
                pos += blob[pos] + 1
            pos += 1
            return lsd, table, descriptor, local, blob[start:pos]
        else:
            break
    raise ValueError("GIF without an image")


class VideoWriter(_Writer):
    """H.264 mp4 (VP9 for .webm) through imageio-ffmpeg's bundled ffmpeg; sizes must be even."""

    def __init__(
        self, path: str | os.PathLike[str], size: tuple[int, int], fps: float, crf: int = 23
    ):
        super().__init__(path, size, fps)
        ffmpeg = require("imageio_ffmpeg", "viz")
        if size[0] % 2 or size[1] % 2:
            raise ValueError(f"video frame sizes must be even, got {size}")
        suffix = self.path.suffix.lower()
        self._tmp = _temp_beside(self.path, suffix)
        if suffix == ".webm":
            codec, params = (
                "libvpx-vp9",
                ["-crf", str(crf + 8), "-b:v", "0", "-deadline", "realtime", "-cpu-used", "8"],
            )
        else:
            codec, params = "libx264", ["-crf", str(crf), "-preset", "ultrafast"]
            if suffix in (".mp4", ".m4v", ".mov"):
                params += ["-movflags", "+faststart"]
        self._gen = ffmpeg.write_frames(
            str(self._tmp),
            self.size,
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            fps=self.fps,
            quality=None,
            codec=codec,
            macro_block_size=1,
            output_params=params,
        )
        self._gen.send(None)

    def write(self, image: Any, frame: int) -> None:
        if image.size != self.size:
            raise ValueError(f"frame size {image.size} differs from {self.size}")
        if image.mode != "RGB":
            image = image.convert("RGB")
        self._gen.send(image.tobytes())
        self.count += 1

    def close(self) -> None:
        self._gen.close()
        if self.count == 0:
            self.abort()
            raise InputError("nothing to write: no frames", self.path)
        _publish(self._tmp, self.path)

    def abort(self) -> None:
        try:
            self._gen.close()
        except Exception:  # noqa: BLE001 - ffmpeg may already be gone; we are cleaning up
            pass
        self._tmp.unlink(missing_ok=True)


class PngFolderWriter(_Writer):
    """A folder of PNGs named ``<frame:06d>.png``, moved into place when all are written."""

    def __init__(self, path: str | os.PathLike[str], size: tuple[int, int], fps: float):
        super().__init__(path, size, fps)
        if self.path.exists() and not self.path.is_dir():
            raise InputError("output exists and is not a folder", self.path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = Path(
            tempfile.mkdtemp(prefix=f".{self.path.name}.", suffix=".part", dir=self.path.parent)
        )

    def write(self, image: Any, frame: int) -> None:
        image.save(self._tmp / f"{int(frame):06d}.png", "PNG", compress_level=1)
        self.count += 1

    def close(self) -> None:
        if self.count == 0:
            self.abort()
            raise InputError("nothing to write: no frames", self.path)
        if not self.path.exists():
            _publish(self._tmp, self.path)
            return
        for item in sorted(self._tmp.iterdir()):
            os.replace(item, self.path / item.name)
        self._tmp.rmdir()

    def abort(self) -> None:
        shutil.rmtree(self._tmp, ignore_errors=True)


def iter_images(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """Sorted image paths of a folder (see :func:`list_images`)."""
    yield from list_images(folder)
