"""Rendering a run: outputs (GIF, mp4, PNG folder), frame sources, drawing, atomicity, CLI."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("PIL")
imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")

from PIL import Image  # noqa: E402

from sensemaking.classes import CLASS_IDS  # noqa: E402
from sensemaking.detections import Detections  # noqa: E402
from sensemaking.errors import InputError  # noqa: E402
from sensemaking.results import Event, FrameResult  # noqa: E402
from sensemaking.viz import _style as st  # noqa: E402
from sensemaking.viz._run import as_run  # noqa: E402
from sensemaking.viz.render import FrameDrawer, RenderOptions, render_frame, render_scene  # noqa: E402

W, H = 800, 300


@dataclass
class Warn:
    frame: int
    situation: str
    objects: tuple[int, ...]
    message: str
    details: dict[str, Any] = field(default_factory=dict)


def occlusion_results(n: int = 40) -> list[FrameResult]:
    """Car #1 parked mid-image; cyclist #2 rides right and is hidden behind #1 in frames 15-22;
    car #3 enters at frame 5 and is missing in frames 28-30."""
    out = []
    for f in range(n):
        rows, events = [], []
        rows.append((1, [300, 100, 500, 250], CLASS_IDS["car"], 0, -1))
        x = 150 + f * 12
        hidden = 15 <= f <= 22
        rows.append(
            (
                2,
                [x, 120, x + 50, 240],
                CLASS_IDS["cyclist"],
                1 if hidden else 0,
                1 if hidden else -1,
            )
        )
        if f == 0:
            events += [Event(0, "starts", (1,)), Event(0, "starts", (2,))]
        if f == 15:
            events.append(Event(15, "hides_behind", (2, 1)))
        if f == 23:
            events.append(Event(23, "unhides_from_behind", (2, 1)))
        if f >= 5:
            missing = 28 <= f <= 30
            rows.append((3, [20 + f, 40, 100 + f, 90], CLASS_IDS["car"], 2 if missing else 0, -1))
            if f == 5:
                events.append(Event(5, "enters_fov", (3,)))
            if f == 28:
                events.append(Event(28, "missing_detections", (3,)))
        k = len(rows)
        tracks = Detections(
            xyxy=np.array([r[1] for r in rows], dtype=float),
            class_id=[r[2] for r in rows],
            tracker_id=[r[0] for r in rows],
            frame=f,
            data={
                "state": np.array([r[3] for r in rows]),
                "occluder": np.array([r[4] for r in rows]),
                "visibility": np.zeros(k, dtype=int),
                "hidden_frames": np.zeros(k, dtype=int),
            },
        )
        out.append(FrameResult(f, tracks, sorted(events)))
    return out


def occlusion_run(**kw: Any):
    warnings = [
        Warn(16, "HIDDEN_ENTITY", (2, 1), "#2 cyclist hidden behind #1 car may reappear in front")
    ]
    return as_run(
        occlusion_results(), warnings=warnings, width=W, height=H, fps=10.0, name="synthetic", **kw
    )


# style ----------------------------------------------------------------------------------------
def test_track_colours_are_stable_and_distinct_for_neighbours():
    assert st.track_rgb(7) == st.track_rgb(7) == st.track_rgb(7 + st.N_TRACK_COLOURS)
    colours = [st.track_rgb(i) for i in range(st.N_TRACK_COLOURS)]
    assert len(set(colours)) == st.N_TRACK_COLOURS
    assert st.palette()[st.track_slot(7)] == st.track_rgb(7)


def test_captions_and_event_sentences():
    assert st.track_caption(5, CLASS_IDS["cyclist"], 1, 2) == "#5 cyclist hidden behind #2"
    assert st.track_caption(5, CLASS_IDS["car"], 2) == "#5 car missing"
    assert st.track_caption(5, 0, 0) == "#5"
    classes = {5: CLASS_IDS["cyclist"], 2: CLASS_IDS["car"]}
    assert st.event_sentence("hides_behind", (5, 2), classes) == "#5 cyclist hides behind #2 car"
    assert st.event_sentence("made_up", (1, 2)) == "made_up(1, 2)"
    # a constant of a user's encoding is no track id: shown as it is
    assert st.event_sentence("near", (5, "left")) == "near(5, left)"
    assert st.warning_sentence(Warn(1, "hidden_entity", (5,), "")) == "HIDDEN_ENTITY: #5"


# drawing --------------------------------------------------------------------------------------
def test_plain_canvas_size_scale_and_strip():
    run = occlusion_run()
    d = FrameDrawer(run)
    assert d.scale == pytest.approx(640 / W)
    assert d.image_size == (640, 240)
    assert d.size[0] % 2 == 0 and d.size[1] % 2 == 0 and d.size[1] > 240
    im = d.draw(3)
    assert im.mode == "P" and im.size == d.size


def _rgb(im: Image.Image) -> np.ndarray:
    return np.asarray(im.convert("RGB")).astype(int)


def test_hidden_track_is_dashed_and_captioned():
    run = occlusion_run()
    drawer = FrameDrawer(run, scale=1.0, options=RenderOptions(trail=0, grid=False))
    im = _rgb(drawer.draw(18))
    colour = np.array(st.track_rgb(2))
    x1 = 150 + 18 * 12
    top = im[120, x1 : x1 + 50]
    on = np.all(np.abs(top - colour) < 3, axis=1)
    assert 0.3 < on.mean() < 0.9, "the hidden box's edge should alternate dashes and gaps"
    # a visible box's edge is solid
    car = im[100, 300:500]
    assert np.all(np.abs(car - np.array(st.track_rgb(1))) < 3, axis=1).mean() > 0.9
    # the caption was drawn from these words
    assert {"hidden", "behind", "cyclist"} <= set(drawer.text.cache)


def test_warned_objects_get_a_red_frame_and_warning_caption():
    run = occlusion_run()
    drawer = FrameDrawer(run, scale=1.0, options=RenderOptions(trail=0, grid=False))
    im = _rgb(drawer.draw(16))
    red = np.array(st.palette()[st.WARNING])
    assert np.all(np.abs(im[100 - 4, 300:500] - red) < 3, axis=1).mean() > 0.8
    assert "WARNING" in drawer.text.cache
    # long after the warning, no red frame
    im_late = _rgb(drawer.draw(39))
    assert np.all(np.abs(im_late[100 - 4, 300:500] - red) < 3, axis=1).mean() < 0.1


def test_trails_follow_past_centres():
    run = occlusion_run()
    drawer = FrameDrawer(run, scale=1.0, options=RenderOptions(trail=10, grid=False))
    im = _rgb(drawer.draw(10))
    colour = np.array(st.track_rgb(2))
    # the cyclist's centre 5 frames ago: x = 150 + 5*12 + 25, y = 180
    assert np.all(np.abs(im[180, 150 + 60 + 25] - colour) < 3)


def test_notes_are_not_drawn_as_warnings():
    note = Warn(16, "BLOCKED_LANE", (), "", {"skipped": "no lanes"})
    run = as_run(occlusion_results(), warnings=[note], width=W, height=H)
    drawer = FrameDrawer(run, scale=1.0)
    drawer.draw(16)
    assert "WARNING" not in drawer.text.cache


# outputs --------------------------------------------------------------------------------------
def test_gif_output(tmp_path: Path):
    out = render_scene(occlusion_run(), tmp_path / "run.gif")
    with Image.open(out) as im:
        assert im.n_frames == 40
        durations = []
        for k in range(im.n_frames):
            im.seek(k)
            durations.append(im.info["duration"])
            assert im.size == FrameDrawer(occlusion_run()).size
    assert durations == [100] * 40
    assert not list(tmp_path.glob(".*part*"))
    assert (out.stat().st_mode & 0o777) != 0o600


def test_gif_timing_does_not_drift(tmp_path: Path):
    out = render_scene(occlusion_run(), tmp_path / "run.gif", fps=30, frames=range(0, 30))
    with Image.open(out) as im:
        total = 0
        for k in range(im.n_frames):
            im.seek(k)
            total += im.info["duration"]
    assert total == 1000


def test_gif_of_rgb_frames_with_changing_palettes(tmp_path: Path):
    from sensemaking.viz._media import GifWriter

    with GifWriter(tmp_path / "rgb.gif", (64, 32), 10) as w:
        for k in range(5):
            a = np.zeros((32, 64, 3), dtype=np.uint8)
            a[:, :, k % 3] = 40 * k + 50
            a[:16, :32] = (255 - 30 * k, 20 * k, 90)
            w.write(Image.fromarray(a), k)
    import imageio.v3 as iio

    frames = iio.imread(tmp_path / "rgb.gif", index=None)
    assert frames.shape[:3] == (5, 32, 64)
    assert tuple(frames[4][0, 0][:3]) == (255 - 120, 80, 90)
    assert tuple(frames[2][20, 50][:3]) == (0, 0, 130)


def test_png_folder_output_keeps_other_files(tmp_path: Path):
    out_dir = tmp_path / "frames"
    out_dir.mkdir()
    (out_dir / "README").write_text("mine")
    render_scene(occlusion_run(), str(out_dir) + "/", frames=range(10, 13))
    assert sorted(p.name for p in out_dir.iterdir()) == [
        "000010.png",
        "000011.png",
        "000012.png",
        "README",
    ]
    fresh = render_scene(occlusion_run(), tmp_path / "new", frames=[0])
    assert [p.name for p in fresh.iterdir()] == ["000000.png"]
    assert not list(tmp_path.glob(".*part*"))


def test_mp4_output(tmp_path: Path):
    from sensemaking.detector import iter_video_frames

    out = render_scene(occlusion_run(), tmp_path / "run.mp4")
    frames = list(iter_video_frames(out))
    size = FrameDrawer(occlusion_run()).size
    assert len(frames) == 40
    assert frames[0].shape == (size[1], size[0], 3)


def test_unknown_output_suffix_fails_before_work(tmp_path: Path):
    with pytest.raises(InputError, match="unknown output type"):
        render_scene(occlusion_run(), tmp_path / "run.png")
    assert not list(tmp_path.iterdir())


def test_failed_render_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    calls = {"n": 0}
    real = FrameDrawer.draw

    def flaky(self: FrameDrawer, frame: int, picture: Any = None) -> Any:
        calls["n"] += 1
        if calls["n"] == 5:
            raise RuntimeError("boom")
        return real(self, frame, picture)

    monkeypatch.setattr(FrameDrawer, "draw", flaky)
    for name in ("run.gif", "run.mp4", "frames"):
        calls["n"] = 0
        with pytest.raises(RuntimeError, match="boom"):
            render_scene(occlusion_run(), tmp_path / name)
    assert list(tmp_path.iterdir()) == []


# frame sources --------------------------------------------------------------------------------
def _write_images(
    folder: Path, frames: range, colour: tuple[int, int, int], size=(W, H), suffix=".png"
) -> None:
    folder.mkdir()
    for f in frames:
        Image.new("RGB", size, colour).save(folder / f"{f:06d}{suffix}")


def test_render_over_numbered_images(tmp_path: Path):
    _write_images(tmp_path / "img", range(0, 40), (200, 30, 30))
    out = render_scene(occlusion_run(), tmp_path / "out", images=tmp_path / "img", frames=[3])
    im = _rgb(Image.open(out / "000003.png"))
    assert im.shape[1] == W  # scale 1 over images up to 1280 px
    assert np.all(np.abs(im[H - 5, 5] - (200, 30, 30)) < 4)


def test_images_named_otherwise_are_taken_in_order(tmp_path: Path):
    folder = tmp_path / "img"
    folder.mkdir()
    for k, colour in enumerate([(10, 10, 10), (10, 200, 10), (10, 10, 200)]):
        Image.new("RGB", (W, H), colour).save(folder / f"shot-{'abc'[k]}.jpg", quality=95)
    im = _rgb(render_frame(occlusion_run(), 6, images=folder, first_frame=5))
    assert np.all(np.abs(im[H - 5, 5] - (10, 200, 10)) < 8)


def test_render_over_a_video(tmp_path: Path):
    video = tmp_path / "in.mp4"
    gen = imageio_ffmpeg.write_frames(str(video), (W, H), fps=10, macro_block_size=1, quality=9)
    gen.send(None)
    for k in range(40):
        a = np.full((H, W, 3), 20, dtype=np.uint8)
        a[:, :, 1] = 5 * k
        gen.send(a.tobytes())
    gen.close()
    out = render_scene(occlusion_run(), tmp_path / "out", video=video, frames=[0, 30])
    late = _rgb(Image.open(out / "000030.png"))
    assert abs(late[H - 5, 5][1] - 150) < 12


def test_images_and_video_are_exclusive(tmp_path: Path):
    with pytest.raises(InputError):
        render_scene(
            occlusion_run(), tmp_path / "x.gif", images=tmp_path, video=tmp_path / "v.mp4"
        )


def test_missing_image_folder_is_an_input_error(tmp_path: Path):
    with pytest.raises(InputError, match="image folder"):
        render_scene(occlusion_run(), tmp_path / "x.gif", images=tmp_path / "nope")


# scene and CLI --------------------------------------------------------------------------------
def _scene_file(tmp_path: Path) -> Path:
    scene_mod = pytest.importorskip("sensemaking.scene")
    rec = scene_mod.SceneRecorder(fps=10.0, image_size=(W, H))
    for r in occlusion_results():
        rec.add(r)
    path = tmp_path / "scene.json"
    rec.scene().save(path)
    return path


def test_render_scene_file_and_cli(tmp_path: Path):
    from sensemaking.cli import main

    scene = _scene_file(tmp_path)
    run = as_run(scene, warnings=None)
    assert run.size() == (W, H) and run.fps == 10.0 and run.name == "scene"
    assert len(run.results) == 40 and run.classes[2] == CLASS_IDS["cyclist"]
    warnings = tmp_path / "w.jsonl"
    warnings.write_text(
        json.dumps(
            {
                "frame": 16,
                "situation": "HIDDEN_ENTITY",
                "objects": [2, 1],
                "message": "cyclist may reappear",
                "details": {},
            }
        )
        + "\n"
    )
    assert (
        main(
            [
                "-q",
                "render",
                str(scene),
                "--output",
                str(tmp_path / "out.gif"),
                "--fps",
                "5",
                "--frames",
                "10:19",
                "--warnings",
                str(warnings),
            ]
        )
        == 0
    )
    with Image.open(tmp_path / "out.gif") as im:
        assert im.n_frames == 10 and im.info["duration"] == 200
    assert main(["-q", "render", str(scene), "--output", str(tmp_path / "bad.txt")]) == 2
    assert (
        main(["-q", "render", str(tmp_path / "none.json"), "--output", str(tmp_path / "o.gif")])
        == 2
    )
    assert (
        main(["-q", "render", str(scene), "--output", str(tmp_path / "o.gif"), "--frames", "9:3"])
        == 2
    )


def test_gif_frames_decode_to_exactly_what_was_drawn(tmp_path: Path):
    """Palette frames are stored as changed rectangles; decoding must give the full frames back."""
    run = occlusion_run()
    out = render_scene(run, tmp_path / "run.gif")
    drawer = FrameDrawer(run)
    with Image.open(out) as gif:
        for k in (0, 1, 14, 15, 16, 30, 39):
            gif.seek(k)
            np.testing.assert_array_equal(_rgb(gif), _rgb(drawer.draw(k)))
    # an unchanged frame is stored as one pixel
    from sensemaking.viz._media import GifWriter

    still = drawer.draw(3)
    with GifWriter(tmp_path / "still.gif", still.size, 10) as w:
        for k in range(3):
            w.write(still, k)
    with Image.open(tmp_path / "still.gif") as gif:
        gif.seek(2)
        np.testing.assert_array_equal(_rgb(gif), _rgb(still))


def test_long_captions_are_cut_to_the_width():
    long = Warn(16, "HIDDEN_ENTITY", (2, 1), "word " * 60)
    run = as_run(occlusion_results(), warnings=[long], width=W, height=H)
    drawer = FrameDrawer(run, scale=0.5)
    drawer.draw(16)
    fitted = drawer._fit("HIDDEN_ENTITY: " + "word " * 60, 200)
    assert fitted.endswith(" ...") and drawer.text.width(fitted) <= 200
    assert drawer._fit("short", 200) == "short"


def test_empty_runs():
    empty_frames = [FrameResult(f, Detections.empty()) for f in range(3)]
    drawer = FrameDrawer(as_run(empty_frames, warnings=None))
    assert drawer.draw(1).size == drawer.size
    with pytest.raises(InputError, match="nothing to render"):
        render_scene([], "unused.gif")


def test_anticipated_reappearance_is_drawn_while_hidden():
    box = [420.0, 120.0, 470.0, 240.0]
    warn = Warn(
        16,
        "HIDDEN_ENTITY",
        (2, 1),
        "may reappear",
        {
            "anticipation": {
                "track": 2,
                "occluder": 1,
                "frame": 16,
                "reappear_frame": 24,
                "box": box,
            }
        },
    )
    run = as_run(occlusion_results(), warnings=[warn], width=W, height=H)
    drawer = FrameDrawer(run, scale=1.0, options=RenderOptions(trail=0, grid=False))
    red = np.array(st.palette()[st.WARNING])

    def red_on_right_edge(frame: int) -> float:
        im = _rgb(drawer.draw(frame))
        return float(np.all(np.abs(im[125:235, 470] - red) < 3, axis=1).mean())

    assert red_on_right_edge(18) > 0.3  # hidden: the expected box is drawn (dotted)
    assert "reappear" in drawer.text.cache
    assert red_on_right_edge(12) == 0.0  # before the warning
    assert red_on_right_edge(23) == 0.0  # the cyclist is visible again


def test_dashed_boxes_far_outside_the_image_are_cheap_and_clipped():
    import time

    from sensemaking.viz.render import _dashed_rect

    calls = []

    class Recorder:
        def line(self, xy: Any, fill: Any, width: int) -> None:
            calls.append(xy)

    _dashed_rect(Recorder(), (-1e7, 10, 1e7, 50), 1, 2, dash=7, gap=5, bounds=(640, 240))
    assert 100 < len(calls) < 400  # only the dashes on screen (two edges of 640 px)
    assert all(-25 < xy[0] < 650 for xy in calls)
    calls.clear()
    _dashed_rect(Recorder(), (10, 10, 70, 34), 1, 2, dash=7, gap=5)
    assert len(calls) == 2 * 5 + 2 * 2  # 60 px edges: 5 dashes; 24 px edges: 2 dashes
    t0 = time.perf_counter()
    huge = as_run(
        [
            FrameResult(
                0,
                Detections(
                    xyxy=[[-1e8, -1e8, 1e8, 1e8]],
                    tracker_id=[1],
                    frame=0,
                    data={"state": np.array([1]), "occluder": np.array([-1])},
                ),
            )
        ],
        warnings=None,
        width=W,
        height=H,
    )
    FrameDrawer(huge).draw(0)
    assert time.perf_counter() - t0 < 2.0
