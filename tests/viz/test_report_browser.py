"""The HTML report as a browser shows it: headless Chromium loads the file offline and we check
the DOM it ends up with (after the page's script ran) and a screenshot."""

from __future__ import annotations

import re
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("PIL")
pytest.importorskip("imageio_ffmpeg")

from conftest import SHARED_DATA  # noqa: E402
from test_render import occlusion_run  # noqa: E402

from sensemaking.viz.report import write_report  # noqa: E402

pytestmark = [pytest.mark.integration, pytest.mark.slow]  # each test starts a browser

CHROMIUM = Path("/usr/bin/chromium")
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--virtual-time-budget=5000",
]


def _chromium(page: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} is absent (Debian: apt-get install chromium)")
    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:
        return subprocess.run(
            [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", *extra, page.resolve().as_uri()],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        )


class _Dom(HTMLParser):
    """The few things we look for in the dumped DOM."""

    def __init__(self) -> None:
        super().__init__()
        self.body: dict[str, str | None] = {}
        self.track_rows: list[str] = []
        self.svg_ids: list[str] = []
        self.stories: list[str] = []
        self.warnings = 0
        self.images: list[str] = []
        self.text: list[str] = []
        self.html = ""

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "body":
            self.body = a
        elif tag == "svg":
            self.svg_ids.append(a.get("id") or "")
        elif tag == "g" and a.get("class") == "track-row":
            self.track_rows.append(a.get("data-track") or "")
        elif tag == "article" and a.get("class") == "story":
            self.stories.append(a.get("data-track") or "")
        elif tag == "li" and a.get("class") == "warning":
            self.warnings += 1
        elif tag == "img":
            self.images.append(a.get("src") or "")

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def _dump(page: Path) -> _Dom:
    dom = _Dom()
    dom.html = _chromium(page, "--dump-dom").stdout
    dom.feed(dom.html)
    return dom


def _story(dom: _Dom, track: int) -> str:
    """The text of one track's story as the browser shows it."""
    m = re.search(
        rf'<article class="story" id="track-{track}"[^>]*>(.*?)</article>', dom.html, re.S
    )
    assert m, f"no story for track {track}"
    return re.sub(r"<[^>]+>", " ", m.group(1))


def test_browser_shows_timeline_stories_warnings_and_images(tmp_path: Path):
    page = write_report(occlusion_run(), tmp_path / "report.html")
    dom = _dump(page)
    assert "timeline-svg" in dom.svg_ids
    assert sorted(dom.track_rows) == ["1", "2", "3"]
    assert sorted(dom.stories) == ["1", "2", "3"]
    text = " ".join(dom.text)
    story = _story(dom, 2)
    assert "cyclist" in story and ("hidden behind" in story or "hides behind" in story)
    assert "#2 cyclist hides behind #1 car" in text  # a key frame's caption
    assert dom.warnings == 1 and "may reappear in front" in text
    assert dom.images and all(src.startswith("data:image/") for src in dom.images)
    # set by the page's own script once every picture decoded
    assert dom.body.get("data-images-decoded") == f"{len(dom.images)}/{len(dom.images)}"


def test_browser_screenshot_is_not_blank(tmp_path: Path):
    from PIL import Image

    page = write_report(occlusion_run(), tmp_path / "report.html")
    shot = tmp_path / "shot.png"
    _chromium(page, f"--screenshot={shot}", "--window-size=1200,1600")
    im = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert im.shape[:2] == (1600, 1200)
    # the timeline's coloured spans are drawn: the visible-state green is on screen
    green = np.all(np.abs(im - (0x2E, 0x9E, 0x5B)) < 12, axis=2)
    assert green.sum() > 500
    assert im.std() > 20


def _kitti_scene():
    """Scene of KITTI 0000 (RRC car detections) tracked by our tracker."""
    det_path = SHARED_DATA / "kitti" / "detections" / "rrc" / "car" / "0000.txt"
    if not det_path.exists():
        pytest.skip(f"{det_path} is absent (benchmark data lives in ../shared/data)")
    from sensemaking.detections import Detections
    from sensemaking.io.kitti import read_kitti_detections, read_kitti_seqinfo
    from sensemaking.scene import SceneRecorder
    from sensemaking.tracker import Tracker, TrackerConfig

    info = read_kitti_seqinfo(SHARED_DATA / "kitti" / "training" / "seqinfo.csv")["0000"]
    dets = read_kitti_detections(det_path, "car")
    size = (info.width, info.height)
    tracker = Tracker(TrackerConfig.for_dataset("kitti", fps=info.fps, image_size=size))
    rec = SceneRecorder(fps=info.fps, image_size=size, metadata={"name": "KITTI 0000"})
    by_frame = dict(dets.frames())
    for f in range(info.length):
        rec.add(tracker.update(by_frame.get(f, Detections.empty()), frame=f))
    return rec.scene()


def test_browser_kitti_report(tmp_path: Path):
    scene = _kitti_scene()
    scene_path = tmp_path / "scene.json"
    scene.save(scene_path)
    gt = SHARED_DATA / "kitti" / "training" / "label_02" / "0000.txt"
    page = write_report(scene_path, tmp_path / "kitti.html", gt=gt, gt_format="kitti")
    html = page.read_text(encoding="utf-8")
    assert not re.search(r"https?:", html)
    dom = _dump(page)
    assert len(dom.track_rows) == len(scene.tracks) > 5
    assert sorted(map(int, dom.stories)) == sorted(scene.tracks)
    text = " ".join(dom.text)
    assert "KITTI 0000" in text and "kitti car" in text
    n_hides = sum(e.name == "hides_behind" for e in scene.events)
    if n_hides:
        assert "hides behind" in text
    assert len(dom.images) >= 5
    assert dom.body.get("data-images-decoded") == f"{len(dom.images)}/{len(dom.images)}"
