"""Shared helpers of the IO tests: the shared-data fixture and bit-exact Detections comparison."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sensemaking.detections import Detections

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
COLUMNS = ("xyxy", "confidence", "class_id", "tracker_id", "frame", "source_row")


@pytest.fixture(scope="module")
def data() -> Path:
    if not DATA.is_dir():
        pytest.skip("../shared/data is absent")
    return DATA


def assert_same(a: Detections, b: Detections, skip: tuple[str, ...] = (), where: object = "") -> None:
    """Every column identical: same dtype, same values bit for bit (signed zeros included)."""
    assert len(a) == len(b), where
    for name in COLUMNS:
        if name not in skip:
            same_array(getattr(a, name), getattr(b, name), f"{where} {name}")
    if "data" not in skip:
        assert sorted(a.data) == sorted(b.data), where
        for key in a.data:
            same_array(a.data[key], b.data[key], f"{where} data[{key!r}]")


def same_array(x: np.ndarray, y: np.ndarray, name: str) -> None:
    assert x.dtype == y.dtype and x.shape == y.shape, name
    assert np.array_equal(x, y), name
    if x.dtype.kind == "f":
        assert np.array_equal(np.signbit(x), np.signbit(y)), name
