"""Helpers that tests in several folders import: bit-exact Detections comparison (IO tests) and
the cost of an answer under tracking.lp and plain frame problems (encoding and tracker tests)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import clingo
import numpy as np

from sensemaking.abduction.problem import FrameProblem
from sensemaking.abduction.solver import load_encoding
from sensemaking.detections import Detections

ENCODING = load_encoding()
COLUMNS = ("xyxy", "confidence", "class_id", "tracker_id", "frame", "source_row")


def assert_same(
    a: Detections, b: Detections, skip: tuple[str, ...] = (), where: object = ""
) -> None:
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


# ---- the encoding: optimal answers and their cost ----------------------------------------
def optimal(
    facts: str, consts: dict[str, int] | None = None, extra: str = ""
) -> list[tuple[int, list[str]]]:
    """Every optimal answer (cost, sorted shown atoms), distinct in the shown atoms."""
    opts = ["--opt-mode=optN", "--warn=none", "0"] + [
        f"-c{k}={v}" for k, v in (consts or {}).items()
    ]
    ctl = clingo.Control(opts)
    ctl.add("base", [], ENCODING)
    ctl.add("base", [], facts + "\n" + extra)
    ctl.ground([("base", [])])
    found: dict[tuple[str, ...], int] = {}

    def on_model(m: clingo.Model) -> None:
        if (
            m.optimality_proven or not m.cost
        ):  # no weak constraint grounded: every model is optimal
            found[tuple(sorted(str(s) for s in m.symbols(shown=True)))] = sum(m.cost)

    result = ctl.solve(on_model=on_model)
    assert result.satisfiable, "the encoding must always have an answer"
    return sorted((c, list(a)) for a, c in found.items())


def cost(facts: str, consts: dict[str, int] | None = None) -> int:
    return optimal(facts, consts)[0][0]


def facts_text(p: FrameProblem) -> str:
    """The whole problem's facts (tracks renumbered 0..T-1 in their order) as program text."""
    component, _, _ = p.whole()
    return "".join(f"{s}." for s in component.facts())


def cost_of(problem: FrameProblem, answer) -> int:
    """The whole frame's cost of an answer's actions and events (forced into the program)."""
    _, ids, _ = problem.whole()
    local = {t: i for i, t in enumerate(ids)}
    forced = [f":- not assign({local[t]},d({d}))." for t, d in answer.assign.items()]
    forced += [f":- not resume({local[t]},d({d}))." for t, d in answer.resume.items()]
    forced += [f":- not start(d({d}))." for d in answer.start]
    forced += [f":- not {n}({local[t]})." for n in ("end", "halt") for t in getattr(answer, n)]

    def term(a) -> str:
        return str(local[a]) if isinstance(a, int) else f"d({a.row})"

    forced += [
        f":- not occurs({n}({','.join(term(a) for a in args)}))." for n, args in answer.events
    ]
    return cost(facts_text(problem) + "\n".join(forced))


def problem(track_id: Sequence[int], n_dets: int, **columns: Any) -> FrameProblem:
    """A frame problem of plain tracks (active, class 1, none tentative, expired, outside, at the
    border or overlapped) and ``n_dets`` plain detections (confidence 900, class 1); ``columns``
    set any field (lists become arrays)."""
    n = len(track_id)
    fields: dict[str, Any] = {
        "track_id": np.array(track_id),
        "active": np.ones(n, dtype=bool),
        "track_class": np.ones(n, dtype=np.int64),
        "det_conf": np.full(n_dets, 900, dtype=np.int64),
        "det_class": np.ones(n_dets, dtype=np.int64),
        "det_border": np.zeros(n_dets, dtype=bool),
        "det_overlapped": np.zeros(n_dets, dtype=bool),
    }
    for name in ("tentative", "expired", "outside", "at_border", "overlapped"):
        fields[name] = np.zeros(n, dtype=bool)
    fields.update({k: v if v is None else np.asarray(v) for k, v in columns.items()})
    return FrameProblem(**fields)
