"""The fixed-lag look-ahead (issue 27): k = 0 is the online tracker, a swap at a crossing is
undone by the frames that follow, the last k frames are flushed, outputs land at their frames."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sensemaking.abduction.components import SolverCache
from sensemaking.cli import main
from sensemaking.config import TrackerConfig
from sensemaking.detections import Detections
from sensemaking.io.mot import read_mot
from sensemaking.lookahead import LookaheadTracker, make_tracker
from sensemaking.pipeline import Pipeline
from sensemaking.results import FrameResult
from sensemaking.synthetic import crossing_scene, occlusion_suite
from sensemaking.tracker import Tracker

WIDTH, HEIGHT = 40.0, 100.0


def walkers(n: int = 20, jitter: float = 1.0, before: float = 3.0) -> Iterator[tuple[int, Any]]:
    """Two people of one size walking towards each other at 10 px/frame, one row of the image,
    crossing at frame 10; the boxes drawn ``before`` px apart at frame 9 and ``jitter`` px
    towards each other's side at frame 10. Yields ``(frame, Detections)``; row 0 is person A."""
    for t in range(n):
        a, b = 100.0 + 10 * t, 300.0 - 10 * t
        if t == 9:
            a, b = a - before, b + before
        if t == 10:
            a, b = a + jitter, b - jitter
        boxes = np.array(
            [[a - WIDTH / 2, 100, a + WIDTH / 2, 200], [b - WIDTH / 2, 100, b + WIDTH / 2, 200]]
        )
        yield (
            t,
            Detections(
                xyxy=boxes,
                confidence=np.array([0.9, 0.9]),
                class_id=np.zeros(2, dtype=np.int64),
                frame=np.full(2, t),
            ),
        )


def ids_of_a(results: list[FrameResult], frames) -> list[int]:
    """The id on person A's box (its detection, row 0) at each frame."""
    a_box = {f: d.xyxy[0] for f, d in frames}
    out = []
    for r in results:
        at = np.flatnonzero(np.all(r.tracks.xyxy == a_box[r.frame], axis=1))
        assert len(at) == 1
        out.append(int(r.tracks.tracker_id[at[0]]))
    return out


def config() -> TrackerConfig:
    return TrackerConfig(fps=10.0, image_size=(1000, 400))


def online(frames, cfg: TrackerConfig) -> list[FrameResult]:
    tracker = Tracker(cfg, solver_cache=SolverCache())
    return [tracker.update(d, f) for f, d in frames]


def delayed(frames, cfg: TrackerConfig, lag: int) -> tuple[list[FrameResult], list[int]]:
    """The look-ahead's results, and how many each push returned."""
    la = LookaheadTracker(Tracker(cfg, solver_cache=SolverCache()), lag=lag)
    out: list[FrameResult] = []
    counts = []
    for f, d in frames:
        got = la.push(d, f)
        counts.append(len(got))
        out += got
    return out + la.flush(), counts


def same(a: FrameResult, b: FrameResult) -> bool:
    return (
        a.frame == b.frame
        and a.events == b.events
        and np.array_equal(a.tracks.tracker_id, b.tracks.tracker_id)
        and np.array_equal(a.tracks.xyxy, b.tracks.xyxy)
        and np.array_equal(a.tracks.data["state"], b.tracks.data["state"])
    )


@pytest.mark.parametrize("scene", occlusion_suite(0)[:4], ids=lambda s: s.name)
def test_lag_zero_is_the_online_tracker(scene) -> None:
    cfg = TrackerConfig(fps=scene.fps, image_size=(scene.width, scene.height))
    base = online(scene.frames(), cfg)
    mine, counts = delayed(scene.frames(), cfg, lag=0)
    assert counts == [1] * scene.n_frames  # every frame final at once
    assert len(mine) == len(base) and all(same(a, b) for a, b in zip(base, mine, strict=True))


def test_make_tracker_is_the_online_tracker_without_lookahead() -> None:
    tracker = Tracker(config(), solver_cache=SolverCache())
    assert make_tracker(tracker) is tracker
    wrapped = make_tracker(Tracker(config().replace(lookahead_s=0.3)))
    assert isinstance(wrapped, LookaheadTracker) and wrapped.lag == 3


def test_snapshot_restore_replays_the_same_frames() -> None:
    frames = list(crossing_scene(1, gap=6).frames())
    tracker = Tracker(config(), solver_cache=SolverCache())
    for f, d in frames[:10]:
        tracker.update(d, f)
    state = tracker.snapshot()
    first = [tracker.update(d, f) for f, d in frames[10:]]
    tracker.restore(state)
    again = [tracker.update(d, f) for f, d in frames[10:]]
    assert all(same(a, b) for a, b in zip(first, again, strict=True))


def test_the_online_tracker_swaps_at_the_crossing_the_lookahead_does_not() -> None:
    frames = list(walkers())
    base = ids_of_a(online(frames, config()), frames)
    assert len(set(base)) == 2  # online: A's box carries B's id at the crossing frame
    mine, _ = delayed(frames, config(), lag=3)
    assert len(set(ids_of_a(mine, frames))) == 1  # the three frames after tell them apart
    assert [r.frame for r in mine] == [f for f, _ in frames]


def test_flush_decides_the_last_frames_in_order() -> None:
    frames = list(crossing_scene(2, gap=4).frames())
    mine, counts = delayed(frames, config(), lag=5)
    assert counts == [0] * 5 + [1] * (len(frames) - 5)
    assert [r.frame for r in mine] == [f for f, _ in frames]
    # where nothing is contested the look-ahead changes nothing
    base = online(frames, config())
    assert all(same(a, b) for a, b in zip(base, mine, strict=True))


def test_the_pipeline_places_delayed_results_at_their_frames() -> None:
    frames = list(walkers())
    la = LookaheadTracker(Tracker(config(), solver_cache=SolverCache()), lag=4)
    seen: list[int] = []

    class Sink:
        def frame(self, result: FrameResult, warnings: list) -> None:
            seen.append(result.frame)

        def skip(self, first: int, last: int) -> None:
            seen.extend(range(first, last + 1))

        def finish(self) -> None:
            pass

        def abort(self, interrupted: bool = False) -> None:
            pass

    with Pipeline(la, sinks=[Sink()]) as pipe:  # type: ignore[list-item]
        with pytest.raises(TypeError):
            pipe.step(0, frames[0][1])
        steps = pipe.advance(0, frames[0][1])
        assert steps == []  # nothing final yet
        summary = pipe.run(frames[1:], last_frame=30)
    assert seen == list(range(31))
    assert summary.frames == 31


def _write_det(path: Path, frames) -> None:
    lines = []
    for f, d in frames:
        for (x1, y1, x2, y2), c in zip(d.xyxy, d.confidence, strict=True):
            lines.append(
                f"{f + 1},-1,{x1:.2f},{y1:.2f},{x2 - x1:.2f},{y2 - y1:.2f},{c:.2f},-1,-1,-1"
            )
    path.write_text("\n".join(lines) + "\n")


def test_track_cli_writes_final_outputs_at_their_frames(tmp_path: Path) -> None:
    det = tmp_path / "det.txt"
    frames = list(walkers(n=24))
    _write_det(det, frames)
    common = ["--format", "mot", "--fps", "10", "--image-size", "1000x400", "--detections"]

    def run(name: str, *extra: str) -> tuple[Path, Path]:
        out, ev = tmp_path / f"{name}.txt", tmp_path / f"{name}.jsonl"
        args = ["track", *common, str(det), "--output", str(out), "--events", str(ev)]
        assert main(["--quiet", *args, *extra]) == 0
        return out, ev

    base, base_ev = run("online")
    zero, zero_ev = run("zero", "--lookahead", "0")
    assert base.read_bytes() == zero.read_bytes() and base_ev.read_bytes() == zero_ev.read_bytes()
    look, look_ev = run("look", "--lookahead", "0.3")
    res, inp = read_mot(look, kind="results"), read_mot(det, kind="det")
    # every box written at its own frame is an input box of that frame, the last ones included
    boxes = {(int(f), tuple(np.round(b, 1))) for f, b in zip(inp.frame, inp.xyxy, strict=True)}
    assert all(
        (int(f), tuple(np.round(b, 1))) in boxes for f, b in zip(res.frame, res.xyxy, strict=True)
    )
    assert set(res.frame.tolist()) == set(range(1, 25))
    a_boxes = {(f + 1, tuple(np.round(d.xyxy[0], 1))) for f, d in frames}

    def ids_on_a(found: Detections) -> set[int]:
        return {
            int(t)
            for f, t, b in zip(found.frame, found.tracker_id, found.xyxy, strict=True)
            if (int(f), tuple(np.round(b, 1))) in a_boxes
        }

    assert len(ids_on_a(res)) == 1  # person A keeps one id through the crossing
    assert len(ids_on_a(read_mot(base, kind="results"))) == 2  # online, it does not
    events = [json.loads(line) for line in look_ev.read_text().splitlines()]
    assert [e["frame"] for e in events] == sorted(e["frame"] for e in events)


def test_lookahead_option_checks_its_range(tmp_path: Path, capsys) -> None:
    det = tmp_path / "det.txt"
    _write_det(det, list(walkers(n=3)))
    code = main(
        [
            "track",
            "--format",
            "mot",
            "--fps",
            "10",
            "--detections",
            str(det),
            "--output",
            str(tmp_path / "o.txt"),
            "--lookahead",
            "-1",
        ]
    )
    assert code == 2
    assert "--lookahead" in capsys.readouterr().err


def test_track_cli_places_events_warnings_and_scene_at_their_frames(tmp_path: Path) -> None:
    """Figure 1's scene has no contested frame: with a 0.5 s look-ahead every output, written
    5 frames late, must be the online run's, byte for byte (tracks, events, warnings, scene)."""
    from sensemaking.io.kitti import write_kitti
    from sensemaking.synthetic import figure1_scene

    scene = figure1_scene()
    det = tmp_path / "det.txt"
    write_kitti(det, scene.detections)
    size = f"{scene.width}x{scene.height}"
    files = {}
    for lookahead in ("0", "0.5"):
        out = tmp_path / f"run{lookahead}"
        paths = [out.with_suffix(s) for s in (".txt", ".jsonl", ".warn.jsonl", ".json")]
        args = ["--quiet", "track", "--format", "kitti", "--fps", str(scene.fps)]
        args += ["--image-size", size, "--detections", str(det), "--output", str(paths[0])]
        args += ["--events", str(paths[1]), "--warnings", str(paths[2]), "--scene", str(paths[3])]
        assert main([*args, "--lookahead", lookahead]) == 0
        files[lookahead] = [p.read_bytes() for p in paths]
    assert all(files["0"]) and files["0"][2].count(b"\n") > 0  # tracks, events, warnings, scene
    assert files["0"] == files["0.5"]


def test_the_cache_tells_the_cost_of_a_part_it_solved() -> None:
    """The look-ahead reads the tracker's cache for a part's optimal cost: the cost of each part
    solved on its own is remembered, and a part never solved is not."""
    frames = list(crossing_scene(1, gap=6).frames())
    tracker = Tracker(config(), solver_cache=SolverCache())
    for f, d in frames[:12]:
        tracker.update(d, f)
    f, d = frames[12]
    problem = tracker.problem(d)
    parts = problem.components()
    assert parts
    costs = []
    for component, _, _ in parts:
        alone = tracker.solver.solver.solve_facts(component.facts(tracker.solver.solver.uses))
        cost = tracker.solver.remembered_cost(component)
        if cost is not None:
            costs.append(cost)
            assert alone is not None and cost == alone.cost
    tracker.update(d, f)  # solves this frame's parts: each is remembered now
    assert all(tracker.solver.remembered_cost(c) is not None for c, _, _ in parts)
    fresh = Tracker(config(), solver_cache=SolverCache())
    assert all(fresh.solver.remembered_cost(c) is None for c, _, _ in parts)


# -- the continuity term and the crowd budget (issue 27, 2026-11-28) ------------------------------
def side_by_side(n: int = 22) -> list[tuple[int, Any]]:
    """Two people of one size walking right at 10 px/frame, 20 px apart in height (person A
    above); at frames 10-12 their boxes are drawn 12 px towards each other's row (so they are
    crossed in height), then back. Row 0 is person A."""
    out = []
    for t in range(n):
        x = 100.0 + 10 * t
        ya, yb = 100.0, 120.0
        if 10 <= t < 13:
            ya, yb = ya + 12, yb - 12
        boxes = np.array([[x - 20, ya, x + 20, ya + 100], [x - 20, yb, x + 20, yb + 100]])
        det = Detections(
            xyxy=boxes,
            confidence=np.array([0.9, 0.9]),
            class_id=np.zeros(2, dtype=np.int64),
            frame=np.full(2, t),
        )
        out.append((t, det))
    return out


def run_lookahead(frames, cfg: TrackerConfig, **kw: Any) -> tuple[list[FrameResult], dict]:
    la = LookaheadTracker(Tracker(cfg, solver_cache=SolverCache()), **kw)
    out: list[FrameResult] = []
    for f, d in frames:
        out += la.push(d, f)
    return out + la.flush(), la.stats


def test_the_continuity_term_keeps_the_identity_the_encoding_alone_swaps() -> None:
    """Over frames 10-13 the encoding's costs alone prefer the chain where A and B change ids
    for good (the Kalman filters follow the crossed boxes); the chain that keeps each box
    near its motion from before frame 10 is chosen with the continuity term."""
    frames = side_by_side()
    plain, _ = run_lookahead(frames, config(), lag=3)
    ids = ids_of_a(plain, frames)
    assert ids[-1] != ids[0]  # without the term: A leaves with B's id
    kept, stats = run_lookahead(frames, config(), lag=3, continuity=300)
    ids = ids_of_a(kept, frames)
    assert ids[-1] == ids[0] and ids[:10] == [ids[0]] * 10
    assert [r.frame for r in kept] == [f for f, _ in frames]
    assert stats["rollouts"] > 0


def test_the_continuity_term_changes_nothing_uncontested() -> None:
    frames = list(crossing_scene(2, gap=4).frames())
    base = online(frames, config())
    mine, _ = run_lookahead(frames, config(), lag=5, continuity=1000)
    assert all(same(a, b) for a, b in zip(base, mine, strict=True))


def crossing_rows(pairs: int = 8) -> list[tuple[int, Any]]:
    """``pairs`` walker pairs (as :func:`walkers`), one per row 120 px apart, pair i crossing
    at frame 8 + i: a crowd with one crossing a frame. Rows 2i and 2i + 1 are pair i."""
    out = []
    for t in range(30):
        boxes = []
        for i in range(pairs):
            tc = 8 + i
            a, b = 200.0 + 10 * (t - tc), 200.0 - 10 * (t - tc)
            if t == tc - 1:
                a, b = a - 3, b + 3
            if t == tc:
                a, b = a + 1, b - 1
            y = 20.0 + 120 * i
            boxes += [[a - 20, y, a + 20, y + 100], [b - 20, y, b + 20, y + 100]]
        det = Detections(
            xyxy=np.array(boxes),
            confidence=np.full(len(boxes), 0.9),
            class_id=np.zeros(len(boxes), dtype=np.int64),
            frame=np.full(len(boxes), t),
        )
        out.append((t, det))
    return out


def swapped_pairs(results: list[FrameResult], frames, pairs: int) -> int:
    """How many pairs' first person carries more than one id over the frames."""
    n = 0
    for i in range(pairs):
        box = {f: d.xyxy[2 * i] for f, d in frames}
        ids = set()
        for r in results:
            at = np.flatnonzero(np.all(r.tracks.xyxy == box[r.frame], axis=1))
            ids.update(r.tracks.tracker_id[at].tolist())
        n += len(ids) > 1
    return n


def test_the_crowd_budget_pays_for_the_crossings_of_a_crowd() -> None:
    """One crossing a frame among 16 people: one unit a frame runs out of credit after a few
    crossings; counted in candidate pairs, a small contested part in a large frame is cheap to
    roll forward: more contested frames are rolled and fewer swaps are left."""
    frames, cfg = crossing_rows(), TrackerConfig(fps=10.0, image_size=(1000, 1000))
    swaps = swapped_pairs(online(frames, cfg), frames, 8)
    even, even_stats = run_lookahead(frames, cfg, lag=3)
    crowd, crowd_stats = run_lookahead(frames, cfg, lag=3, crowd_budget=True)
    assert crowd_stats["over_budget"] < even_stats["over_budget"]
    assert crowd_stats["rollouts"] > even_stats["rollouts"]
    assert swapped_pairs(crowd, frames, 8) < swapped_pairs(even, frames, 8) <= swaps


def test_the_settings_reach_the_lookahead() -> None:
    cfg = config().replace(lookahead_s=0.3, lookahead_continuity=250, lookahead_crowd_budget=True)
    la = make_tracker(Tracker(cfg))
    assert isinstance(la, LookaheadTracker) and la.continuity == 250 and la.crowd
    with pytest.raises(ValueError):
        LookaheadTracker(Tracker(config()), lag=2, continuity=-1)
