"""Reading frames: image folders and videos (any ffmpeg format; GIF through imageio).

Used by the detector (``track --source``) and by rendering; needs the ``viz`` extra for the
actual decoding (Pillow, imageio, imageio-ffmpeg), imported only when a frame is read.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.errors import InputError, require

__all__ = [
    "IMAGE_SUFFIXES",
    "VIDEO_SUFFIXES",
    "list_images",
    "iter_video_frames",
    "ImageFolder",
    "VideoFrames",
]

IMAGE_SUFFIXES = frozenset({".png", ".jpg", ".jpeg", ".bmp", ".webp", ".tif", ".tiff", ".ppm"})
VIDEO_SUFFIXES = frozenset({".mp4", ".m4v", ".mov", ".mkv", ".avi", ".webm"})


def list_images(folder: str | os.PathLike[str]) -> list[Path]:
    """Image files of a folder (by suffix), sorted by name. Raises InputError when there are
    none."""
    root = Path(folder)
    if not root.is_dir():
        raise InputError("no such image folder", root)
    files = sorted(p for p in root.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    if not files:
        raise InputError(f"no images ({', '.join(sorted(IMAGE_SUFFIXES))}) in the folder", root)
    return files


class ImageFolder:
    """Frames from an image folder.

    Files whose names are all integers (``000001.jpg`` in MOT, ``000000.png`` in KITTI) are
    looked up by frame number; otherwise the i-th file (sorted) is frame ``first_frame + i``.
    """

    def __init__(self, folder: str | os.PathLike[str], first_frame: int | None = None):
        self.files = list_images(folder)
        stems = [p.stem for p in self.files]
        if first_frame is None and all(s.isdigit() for s in stems):
            self.index = {int(s): p for s, p in zip(stems, self.files, strict=True)}
        else:
            start = 0 if first_frame is None else int(first_frame)
            self.index = {start + i: p for i, p in enumerate(self.files)}
        image = require("PIL.Image", "viz")
        with image.open(self.files[0]) as im:
            self.size: tuple[int, int] = im.size

    def get(self, frame: int, size: tuple[int, int] | None = None) -> Any:
        """The RGB Pillow image of ``frame`` resized to ``size`` (None when there is no such
        file)."""
        path = self.index.get(int(frame))
        if path is None:
            return None
        image = require("PIL.Image", "viz")
        im = image.open(path)
        if size is not None and size != im.size:
            im.draft("RGB", size)  # JPEG: decode at reduced scale
        im = im.convert("RGB")
        if size is not None and im.size != size:
            im = im.resize(size, image.Resampling.BILINEAR)
        return im


class VideoFrames:
    """Frames of a video read in order; video frame ``k`` is frame ``first_frame + k``."""

    def __init__(self, path: str | os.PathLike[str], first_frame: int = 0):
        self.first_frame = int(first_frame)
        self._iter = iter_video_frames(path)
        try:
            self._next: np.ndarray | None = next(self._iter)
        except StopIteration:
            raise InputError("the video has no frames", path) from None
        self._pos = self.first_frame
        first: np.ndarray = self._next
        self.size = (int(first.shape[1]), int(first.shape[0]))

    def get(self, frame: int, size: tuple[int, int] | None = None) -> Any:
        """The RGB image of ``frame`` (frames must be asked in increasing order), or None."""
        while self._next is not None and self._pos < frame:
            self._advance()
        if self._next is None or self._pos != frame:
            return None
        image = require("PIL.Image", "viz")
        im = image.fromarray(self._next, "RGB")
        if size is not None and im.size != size:
            im = im.resize(size, image.Resampling.BILINEAR)
        return im

    def _advance(self) -> None:
        self._next = next(self._iter, None)
        self._pos += 1

    def close(self) -> None:
        close = getattr(self._iter, "close", None)
        if close is not None:
            close()


def iter_video_frames(path: str | os.PathLike[str]) -> Iterator[np.ndarray]:
    """Frames of a video file (any ffmpeg format; GIF through imageio) or of an image folder
    (sorted names), in order, each ``H x W x 3`` uint8 RGB. Needs the ``viz`` extra."""
    p = Path(path)
    if p.is_dir():
        image = require("PIL.Image", "viz")
        for f in list_images(p):
            with image.open(f) as im:
                yield np.asarray(im.convert("RGB"))
        return
    if not p.is_file():
        raise InputError("no such video file", p)
    if p.suffix.lower() == ".gif":
        iio = require("imageio.v3", "viz")
        for frame in iio.imiter(p):
            arr = np.asarray(frame)
            if arr.ndim == 2:
                arr = np.repeat(arr[..., None], 3, axis=2)
            yield np.ascontiguousarray(arr[..., :3]).astype(np.uint8)
        return
    ffmpeg = require("imageio_ffmpeg", "viz")
    try:
        gen = ffmpeg.read_frames(str(p), pix_fmt="rgb24")
        meta: dict[str, Any] = gen.__next__()
    except (OSError, RuntimeError, StopIteration) as exc:
        raise InputError(f"cannot read the video: {exc}", p) from exc
    w, h = (int(v) for v in meta["size"])
    try:
        for raw in gen:
            yield np.frombuffer(raw, dtype=np.uint8).reshape(h, w, 3)
    finally:
        gen.close()
