"""The bridge from ``sensemaking ask`` / ``explain`` to the archive: ``--archive DIR
--sequence DATASET/SEQUENCE`` instead of a scene file."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from sensemaking.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.scene import Scene

__all__ = ["add_archive_options", "scene_from_args"]


def add_archive_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--archive``, ``--sequence`` and ``--key`` (the scene then comes from the archive)."""
    g = parser.add_argument_group("scene from a fleet archive (instead of SCENE; 'fleet' extra)")
    g.add_argument(
        "--archive", metavar="DIR", default=None, help="archive from `sensemaking batch`"
    )
    g.add_argument(
        "--sequence",
        metavar="DATASET/SEQUENCE",
        default=None,
        help="the archived sequence, e.g. kitti-rrc-car/0005 (with --archive)",
    )
    g.add_argument(
        "--key",
        default=None,
        help="which archived result of the sequence (default: the newest successful)",
    )


def scene_from_args(args: argparse.Namespace) -> Scene:
    """The scene of ``args.scene``, or of ``--archive``/``--sequence``. With an archive, a
    positional ``scene`` is the first word of ``args.query`` (argparse fills ``scene`` first).

    Raises:
        InputError: neither or both sources given, or ``--sequence`` without a dataset.
    """
    from sensemaking.scene import Scene

    if args.archive is None:
        if args.sequence is not None or args.key is not None:
            raise InputError("--sequence and --key need --archive DIR")
        if args.scene is None:
            raise InputError("give a scene file, or --archive DIR --sequence DATASET/SEQUENCE")
        return Scene.load(args.scene)
    if args.scene is not None:
        if not hasattr(args, "query"):
            raise InputError("give either a scene file or --archive, not both")
        args.query = [str(args.scene)] + list(args.query)
        args.scene = None
    dataset, sep, sequence = (args.sequence or "").partition("/")
    if not sep or not dataset or not sequence:
        raise InputError("--archive needs --sequence DATASET/SEQUENCE, e.g. kitti-rrc-car/0005")
    from sensemaking.fleet.archive import load_scene

    return load_scene(args.archive, dataset, sequence, key=args.key)
