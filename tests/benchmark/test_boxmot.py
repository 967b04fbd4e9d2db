"""The boxmot peers: motion only, run through update(dets, img) with a blank image."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from sensemaking.benchmark import peers
from sensemaking.detections import Detections

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("boxmot") is None, reason="needs the 'boxmot' extra"
)


def _frames(n: int = 12) -> list[Detections]:
    """Two boxes moving right, one weak flicker every other frame."""
    out = []
    for f in range(n):
        boxes = [[100 + 6 * f, 100, 180 + 6 * f, 220], [500 - 4 * f, 150, 560 - 4 * f, 260]]
        scores = [0.9, 0.85]
        if f % 2:
            boxes.append([900, 40, 930, 80])
            scores.append(0.2)
        out.append(
            Detections(
                xyxy=np.array(boxes, float),
                confidence=scores,
                class_id=1,
                frame=f,
                source_row=np.arange(len(boxes)) + 10 * f,
            )
        )
    return out


def _run(adapter, frames) -> list[Detections]:
    adapter.reset()
    return [adapter.update(d, f)[0] for f, d in enumerate(frames)]


@pytest.mark.parametrize("key", list(peers.BOXMOT_PEERS))
def test_boxmot_peer_keeps_ids_and_reports_input_rows(key: str) -> None:
    frames = _frames()
    adapter = peers.make_peer(key, frame_rate=10.0, image_size=(1242, 375))
    assert isinstance(adapter, peers.BoxmotAdapter) and adapter._img.shape == (375, 1242, 3)
    outs = _run(adapter, frames)
    late = outs[-1]
    assert (
        len(late) == 2 and (late.tracker_id >= 1).all() and len(set(late.tracker_id.tolist())) == 2
    )
    ids_late = {
        tuple(b): t
        for b, t in zip(late.xyxy.round(1).tolist(), late.tracker_id.tolist(), strict=False)
    }
    assert all(tuple(b) in {tuple(x) for x in frames[-1].xyxy.tolist()} for b in ids_late)
    # the same two ids over the last four frames: identities are kept
    assert {int(t) for o in outs[-4:] for t in o.tracker_id} == set(late.tracker_id.tolist())
    assert set(late.source_row.tolist()) <= set(frames[-1].source_row.tolist())
    # only the image's shape is read: noise instead of the blank image changes nothing
    adapter._img = np.random.default_rng(0).integers(0, 255, adapter._img.shape, dtype=np.uint8)
    noisy = _run(adapter, frames)
    for a, b in zip(outs, noisy, strict=False):
        np.testing.assert_array_equal(a.xyxy, b.xyxy)
        np.testing.assert_array_equal(a.tracker_id, b.tracker_id)


def test_boxmot_defaults_name_what_is_switched_off() -> None:
    d = peers.peer_defaults("boxmot-botsort")
    assert d["use_embeddings"] is False and d["use_cmc"] is False and "track_high_thresh" in d
    assert set(peers.BOXMOT_LEFT_OUT) == {"strongsort", "occluboost", "sam2mot"}
    assert set(peers.BOXMOT_PEERS) <= set(peers.TRACKER_NAMES) and set(peers.BOXMOT_PEERS) <= set(
        peers.PEERS
    )
