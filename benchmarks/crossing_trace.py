"""Crossing swaps traced frame by frame (issue 27): where an identity moves to the occluder.

For every MOT17 episode that ``occlusion_errors.py taxonomy`` classifies as *switched to the
occluder's track* (object A, its track X at its last visible frame, the track Y it came back
under, Y having been on the occluder B), the sequence is tracked again in-process with the
preset (as ``sensemaking track`` does) and the first frame of the episode where the two
identities mix is found: Y's box on A, or X's box on B (IoU >= 0.5 with the ground truth). For
that frame it prints the two tracks' predicted boxes and states, the detections on A and B, the
likelihoods of the candidate pairs, the covers / fits facts, the answer the encoding chose
(matches and events) with its cost, and the cheapest answer without the swap (the chosen
matches of X onto B's detection and Y onto A's forbidden) with its cost.

    python benchmarks/crossing_trace.py TAXONOMY.json [--set K=V ...] [--json OUT]

``--set`` traces a run made with other settings (e.g. the identity-swap cost, ``swap_weight``,
which is off in the preset); give the settings the taxonomy's run was made with.

TAXONOMY.json: ``occlusion_errors.py --only mot17 taxonomy RUN --json TAXONOMY.json``.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking import asp
from sensemaking.abduction.solver import load_encoding
from sensemaking.io.mot import read_seqinfo
from sensemaking.io.stream import iter_detection_frames
from sensemaking.settings import load_config
from sensemaking.tracker import Tracker

sys.path.insert(0, str(Path(__file__).resolve().parent))
import occlusion_errors as occ  # noqa: E402

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def gt_objects(seq: str) -> dict[int, dict[int, np.ndarray]]:
    """object id -> frame -> box (x1, y1, x2, y2), as the occlusion measure reads them."""
    item = occ.Item("mot17", seq)
    return occ._gt_objects(item, occ._gt(item, DATA))


def on_object(box: np.ndarray, objs: dict[int, dict[int, np.ndarray]], f: int) -> int | None:
    best, who = 0.5, None
    for o, fr in objs.items():
        if f in fr:
            v = occ._iou(box, fr[f])
            if v >= best:
                best, who = v, o
    return who


def solve(
    consts: dict[str, int], facts: list[str], extra: str = ""
) -> tuple[list[int], list[str]] | None:
    """Optimal cost vector and shown atoms of a component's facts with ``extra`` rules."""
    args = [f"-c {k}={v}" for k, v in consts.items()] + ["--opt-mode=opt"]
    show = "#show m/2. #show hide/2. #show halt/1. #show ignore_trk/1. #show unseen/1."
    text = load_encoding() + "\n" + ". ".join(facts) + ".\n" + extra + show
    ctl = asp.control(args, asp.parsed(text))
    ctl.ground([("base", [])])
    best: tuple[list[int], list[str]] | None = None
    with ctl.solve(yield_=True) as h:
        for m in h:
            best = (list(m.cost), sorted(str(s) for s in m.symbols(shown=True)))
    return best


def trace_sequence(seq: str, eps: list[dict[str, Any]], sets: list[str]) -> list[dict[str, Any]]:
    path = DATA / "mot17" / seq
    info = read_seqinfo(path / "seqinfo.ini")
    config = load_config(
        None,
        "mot",
        {"fps": float(info.fps), "image_size": (info.width, info.height)},
        sets,
    )
    tracker = Tracker(config)
    objs = gt_objects(seq)
    want: dict[int, list[dict[str, Any]]] = {}
    for e in eps:
        for f in range(e["a"], (e.get("frame_after") or e["b"]) + 1):
            want.setdefault(f, []).append(e)
    # per frame: track id -> (predicted box, state), the problem, the answer
    frames: dict[int, dict[str, Any]] = {}
    boxes: dict[int, dict[int, np.ndarray]] = {}  # frame -> track id -> box, if seen
    for frame, dets in iter_detection_frames(
        path / "det" / "det.txt", "mot", image_size=config.image_size, last_frame=info.length
    ):
        tracks_before = tracker.tracks
        ids = tracks_before.id.copy() if len(tracks_before) else np.zeros(0, int)
        pred = tracks_before.kf.peek(1) if len(tracks_before) else np.zeros((0, 4))
        result, answer, problem = tracker.decide(dets, frame, keep_problem=frame in want)
        out = result.tracks
        table = tracker.tracks  # a track seen this frame has been unseen for 0 frames
        seen = set(table.id[table.unseen == 0].tolist()) if len(table) else set()
        boxes[frame] = {
            int(out.tracker_id[i]): out.xyxy[i]
            for i in range(len(out))
            if int(out.tracker_id[i]) in seen
        }
        if frame in want and problem is not None:
            frames[frame] = {
                "ids": ids,
                "pred": pred,
                "uses": tracker.solver.solver.uses,
                "problem": problem,
                "dets": dets,
                "events": result.events,
                "consts": dict(tracker.solver.solver.constants),
            }
    rows = []
    for e in eps:
        rows.append(_trace_episode(e, frames, boxes, objs))
    return rows


def _trace_episode(
    e: dict[str, Any],
    frames: dict[int, dict[str, Any]],
    boxes: dict[int, dict[int, np.ndarray]],
    objs: dict[int, dict[int, np.ndarray]],
) -> dict[str, Any]:
    a_obj, x, y = e["object"], e["id_before"], e["id_after"]
    end = e.get("frame_after") or e["b"]
    # B: the object Y was on at A's last visible frame (or the last frame before it)
    b_obj = None
    for f in range(e["a"], e["a"] - 30, -1):
        if y in boxes.get(f, {}):
            b_obj = on_object(boxes[f][y], objs, f)
            if b_obj is not None:
                break
    # the frame where Y (B's track) first lies on A: the identity the measure counts moves
    # there; X's own first box on another object (its output box, matched or predicted) is
    # noted beside it
    swap, how, x_off = None, "", None
    for f in range(e["a"] + 1, end + 1):
        bx = boxes.get(f, {})
        if x_off is None and x in bx and on_object(bx[x], objs, f) not in (a_obj, None):
            x_off = f
        if y in bx and on_object(bx[y], objs, f) == a_obj:
            swap, how = f, "Y on A"
            break
    row: dict[str, Any] = {
        "seq": e["sequence"],
        "A": a_obj,
        "B": b_obj,
        "X": x,
        "Y": y,
        "a": e["a"],
        "b": e["b"],
        "after": end,
        "swap": swap,
        "how": how,
        "x_off": x_off,
    }
    ctx = {"A": a_obj, "B": b_obj, "objs": objs, "boxes": boxes}
    if x_off is not None and (swap is None or x_off < swap) and x_off in frames:
        row["at_x_off"] = _analyse(dict(row, swap=x_off, how="X off A"), frames[x_off], ctx)
    if swap is None or swap not in frames:
        return row
    return _analyse(row, frames[swap], ctx)


def _analyse(row: dict[str, Any], fr: dict[str, Any], ctx: dict[str, Any]) -> dict[str, Any]:
    """The frame ``row["swap"]``: tracks, detections, the answer and the one without the swap."""
    swap, x, y = row["swap"], row["X"], row["Y"]
    a_obj, b_obj, objs, boxes = ctx["A"], ctx["B"], ctx["objs"], ctx["boxes"]
    p = fr["problem"]
    tid = p.track_id.tolist()
    dets = fr["dets"]
    row["frame_events"] = [str(ev) for ev in fr["events"] if set(ev.args) & {x, y}]
    for name, t in (("X", x), ("Y", y)):
        if t not in tid:
            row[name + "_state"] = "not a live track"
            continue
        i = tid.index(t)
        row[name + "_state"] = ("active" if p.active[i] else "halted") + (
            " tentative" if p.tentative[i] else ""
        )
        j = fr["ids"].tolist().index(t)
        row[name + "_pred"] = [round(float(v)) for v in fr["pred"][j]]
        row[name + "_cand"] = {int(d): int(lk) for (ti, d, lk) in p.cand.tolist() if ti == i}
        row[name + "_covered_by"] = [int(d) for d, ti in p.covers.tolist() if ti == i]
        row[name + "_fits"] = [int(d) for ti, d in p.fits.tolist() if ti == i]
    det_on: dict[int, int | None] = {}
    for j in range(len(dets)):
        det_on[j] = on_object(dets.xyxy[j], objs, swap)

    def who(o: int | None) -> str:
        return "A" if o == a_obj else "B" if o == b_obj else "-" if o is None else f"o{o}"

    near = {int(d) for ti, d, _ in p.cand.tolist() if tid[ti] in (x, y)}
    row["dets"] = {
        j: {
            "on": who(det_on[j]),
            "box": [round(float(v)) for v in dets.xyxy[j]],
            "conf": round(float(dets.confidence[j]), 2),
        }
        for j in range(len(dets))
        if j in near or det_on[j] in (a_obj, b_obj)
    }
    row["gt"] = {
        k: [round(float(v)) for v in objs[o][swap]]
        for k, o in (("A", a_obj), ("B", b_obj))
        if o is not None and swap in objs[o]
    }
    row["history"] = {
        f: {
            n: who(on_object(boxes[f][t], objs, f)) if t in boxes.get(f, {}) else "."
            for n, t in (("X", x), ("Y", y))
        }
        for f in range(swap - 3, swap + 2)
    }
    # the component holding X or Y, solved as chosen and without the swap
    for comp, track_ids, det_rows in p.components():
        if x not in track_ids[: len(comp.tracks)] and y not in track_ids[: len(comp.tracks)]:
            continue
        facts = [str(s) for s in comp.facts(fr["uses"])]
        lx = track_ids.index(x) if x in track_ids else None
        ly = track_ids.index(y) if y in track_ids else None
        da = [k for k, r in enumerate(det_rows) if det_on.get(r) == a_obj]
        dn = [k for k, r in enumerate(det_rows) if det_on.get(r) not in (a_obj, None)]
        forbid = ""
        if ly is not None:
            forbid += "".join(f":- m({ly},d({k})).\n" for k in da)
        if lx is not None:
            forbid += "".join(f":- m({lx},d({k})).\n" for k in dn)
        row["local"] = {"X": lx, "Y": ly, "rows": det_rows, "tracks": track_ids}
        row["facts"] = facts
        chosen = solve(fr["consts"], facts)
        other = solve(fr["consts"], facts, forbid) if forbid else None
        row["chosen"] = chosen
        row["no_swap"] = other
        break
    return row


def _glob(atom: str, tracks: list[int], rows: list[int], label: dict[int, str]) -> str:
    """An answer atom with local names replaced: track ids as tN, detections as their row and
    the object they lie on (A, B, oN, - for none)."""

    def det_name(m: re.Match[str]) -> str:
        row = rows[int(m[1])]
        return f"D{row}:{label.get(row, '?')}"

    atom = re.sub(r"d\((\d+)\)", det_name, atom)
    return re.sub(r"(?<=[(,])(\d+)(?=[,)])", lambda m: f"t{tracks[int(m[1])]}", atom)


def summary(row: dict[str, Any]) -> str:
    """A few lines per traced episode."""
    head = (
        f"{row['seq']} A={row['A']} B={row['B']} X=t{row['X']} Y=t{row['Y']} "
        f"last seen {row['a']} back {row['b']} swap {row['swap']} ({row['how']}); "
        f"X first on another object {row['x_off']}"
    )
    if "local" not in row:
        return head + "\n  (no frame traced)"
    loc = row["local"]
    label = {int(j): d["on"] for j, d in row["dets"].items()}
    out = [head]
    out.append(f"  history {row['history']}")
    for n in ("X", "Y"):
        if row.get(n + "_pred") is None:
            out.append(f"  {n}: {row.get(n + '_state')}")
            continue
        cand = {f"D{d}:{label.get(d, '?')}": lk for d, lk in row[n + "_cand"].items()}
        out.append(
            f"  {n} {row[n + '_state']} pred {row[n + '_pred']} cand {cand} "
            f"covered_by {row[n + '_covered_by']} fits {row[n + '_fits']}"
        )
    out.append(f"  dets {row['dets']} gt {row['gt']}")
    keep = ("m(", "hide(", "occurs(", "halt(", "ignore_trk(")
    for name in ("chosen", "no_swap"):
        ans = row.get(name)
        if not ans:
            out.append(f"  {name}: none")
            continue
        mine = {f"t{row['X']}", f"t{row['Y']}"}
        atoms = [_glob(a, loc["tracks"], loc["rows"], label) for a in ans[1] if a.startswith(keep)]
        atoms = [a for a in atoms if any(t + "," in a or t + ")" in a for t in mine)]
        out.append(f"  {name} cost {ans[0]}: {' '.join(atoms)}")
    if "at_x_off" in row:
        out.append("  -- X's first frame on another object:")
        out += ["  " + line for line in summary(row["at_x_off"]).splitlines()[1:]]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("taxonomy", type=Path)
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--json", type=Path)
    ap.add_argument("--seq", action="append")
    args = ap.parse_args(argv)
    rows = json.loads(args.taxonomy.read_text())
    eps = [
        r
        for r in rows
        if r["bench"] == "mot17" and r.get("cause") == "switched to the occluder's track"
    ]
    by_seq: dict[str, list[dict[str, Any]]] = {}
    for r in eps:
        by_seq.setdefault(r["sequence"], []).append(r)
    out = []
    for seq, es in by_seq.items():
        if args.seq and seq not in args.seq:
            continue
        print(f"tracing {seq}: {len(es)} episodes", file=sys.stderr)
        out += trace_sequence(seq, es, args.set)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1, default=str) + "\n")
    for row in out:
        print(summary(row))


if __name__ == "__main__":
    main()
