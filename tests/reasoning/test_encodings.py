"""The ASP encodings on tiny programs: exact, sorted atoms (clingox style)."""

from __future__ import annotations

import clingo
import numpy as np
import pytest

from sensemaking.reasoning.relations import IA_RELATIONS, INVERSE, interval_relations
from sensemaking.reasoning.situations import SituationSolver, encoding_text, situation_constants


def atoms(
    program: str, *files: str, parts: tuple[str, ...] = ("base",), show: str | None = None
) -> list[str]:
    """Sorted shown atoms of the unique answer set of ``files`` + ``program``."""
    ctl = clingo.Control(["--warn=none"])
    for f in files:
        ctl.add("base", [], encoding_text(f))
    ctl.add("base", [], program + ("" if show is None else "\n#show.\n" + show))
    ctl.ground([(p, []) for p in parts])
    models: list[list[str]] = []
    ctl.solve(on_model=lambda m: models.append(sorted(str(s) for s in m.symbols(shown=True))))
    assert len(models) == 1
    return models[0]


# -- relations.lp ---------------------------------------------------------------------------------
def test_inverse_table_matches_python():
    got = atoms("", "relations.lp", show="#show inverse/2.")
    assert got == sorted(f"inverse({a},{b})" for a, b in INVERSE.items())
    assert atoms("", "relations.lp", show="#show ia/1.") == sorted(
        f"ia({r})" for r in IA_RELATIONS
    )


def test_converse_closer_side_by_side_touching():
    prog = "ra(1,2,0,before,overlaps). ra(3,4,0,overlaps,finishes)."
    assert atoms(prog, "relations.lp", show="#show ra/5.") == [
        "ra(1,2,0,before,overlaps)",
        "ra(2,1,0,after,overlapped_by)",
        "ra(3,4,0,overlaps,finishes)",
        "ra(4,3,0,overlapped_by,finished_by)",
    ]
    # depth order is not read off the y relation: closer/3 is front/3 (relations.pair_front)
    assert atoms(prog, "relations.lp", show="#show closer/3.") == []
    assert atoms(prog + "front(2,1,0).", "relations.lp", show="#show closer/3.") == [
        "closer(2,1,0)"
    ]
    assert atoms(prog, "relations.lp", show="#show side_by_side/3.") == [
        "side_by_side(1,2,0)",
        "side_by_side(2,1,0)",
        "side_by_side(3,4,0)",
        "side_by_side(4,3,0)",
    ]
    assert atoms(prog, "relations.lp", show="#show touching/3.") == [
        "touching(3,4,0)",
        "touching(4,3,0)",
    ]


def test_bottom_lower_is_exactly_the_lower_bottom_relations():
    lp = {
        a[len("bottom_lower(") : -1]
        for a in atoms("", "relations.lp", show="#show bottom_lower/1.")
    }
    # every y relation of proper intervals whose end lies beyond the other's end is listed
    rng = np.random.default_rng(1)
    lo = rng.integers(0, 20, (4000, 2)).astype(float)
    a = np.stack([lo[:, 0], lo[:, 0] + rng.integers(1, 10, 4000)], axis=1)
    b = np.stack([lo[:, 1], lo[:, 1] + rng.integers(1, 10, 4000)], axis=1)
    names = [IA_RELATIONS[c] for c in interval_relations(a, b)]
    assert {n for n, lower in zip(names, a[:, 1] > b[:, 1], strict=False) if lower} == lp
    assert not {n for n, lower in zip(names, a[:, 1] <= b[:, 1], strict=False) if lower} & lp


# -- scene.lp and questions.lp -------------------------------------------------------------------
SCENE = """
scene_frames(0,4). frame(0..4). track(1,cyclist). track(2,car).
first_frame(1,0). last_frame(1,3). first_frame(2,1). last_frame(2,3).
state(1,0,visible). state(1,1,hidden). state(1,2,hidden). state(1,3,visible).
state(2,1,visible). state(2,2,visible). state(2,3,missing).
holds_during(in_fov(1),true,0,3). holds_during(in_fov(2),true,1,3).
holds_during(hidden_by(1,2),true,1,2).
box(2,2,10,20,110,90). in_corridor(2,2).
occurs_at(hides_behind(1,2),1). occurs_at(unhides_from_behind(1,2),3). occurs_at(ends(2),4).
"""


def test_scene_functional_event_calculus_view():
    got = atoms(SCENE, "relations.lp", "scene.lp", show="#show holds_at/3.")
    assert [a for a in got if "in_fov(2)" in a] == [
        "holds_at(in_fov(2),false,0)",
        "holds_at(in_fov(2),false,4)",
        "holds_at(in_fov(2),true,1)",
        "holds_at(in_fov(2),true,2)",
        "holds_at(in_fov(2),true,3)",
    ]
    assert [a for a in got if "hidden_by" in a] == [
        "holds_at(hidden_by(1,2),true,1)",
        "holds_at(hidden_by(1,2),true,2)",
    ]
    assert atoms(SCENE, "relations.lp", "scene.lp", show="#show live/2.")[:3] == [
        "live(1,0)",
        "live(1,1)",
        "live(1,2)",
    ]


def test_questions():
    files = ("questions.lp",)  # standalone over the scene facts
    assert atoms(SCENE, *files, show="#show hidden_episode/4.") == ["hidden_episode(1,2,1,2)"]
    assert atoms(SCENE, *files, show="#show reappeared/4.") == ["reappeared(1,3,1,hidden_by(2))"]
    assert atoms(SCENE, *files, show="#show in_front/3.") == ["in_front(2,2,90)"]
    assert atoms(SCENE, *files, show="#show ended/3. #show final_state/2.") == [
        "ended(1,3,unknown)",
        "ended(2,3,lost)",
        "final_state(1,visible)",
        "final_state(2,missing)",
    ]
    longer = (
        SCENE.replace("scene_frames(0,4).", "scene_frames(0,5).").replace(
            "last_frame(1,3).", "last_frame(1,5)."
        )
        + "state(1,4,missing). state(1,5,visible)."
    )
    got = atoms(longer, *files, show="#show reappeared/4. #show ended/3.")
    assert got == [
        "ended(1,5,scene_end)",
        "ended(2,3,lost)",
        "reappeared(1,3,1,hidden_by(2))",
        "reappeared(1,5,4,missing)",
    ]


# -- situations.lp --------------------------------------------------------------------------------
HEAD = "now(10). frame_ms(100). seq_start(0). "


def _fact(sym: clingo.Symbol):
    if sym.type == clingo.SymbolType.Number:
        return sym.number
    return (sym.name, *map(_fact, sym.arguments)) if sym.arguments else sym.name


def _facts(program: str) -> tuple:
    text = HEAD + program
    return tuple(_fact(clingo.parse_term(f.strip())) for f in text.split(".") if f.strip())


def sit(program: str, part: str, **consts: int) -> list[str]:
    """Sorted warn/2 and info/4 of SituationSolver for the facts of ``program``."""
    return sorted(str(s) for s in SituationSolver([part], consts).answer(_facts(program)))


def test_constants_and_defaults():
    c = situation_constants()
    assert set(c) == {
        "ov_ms",
        "he_lead_ms",
        "rv_area",
        "ss_area",
        "ss_ms",
        "bl_ms",
        "ev_ms",
        "stop_cms",
        "lane_half_cm",
        "ov_gap_cm",
        "ss_ttc",
        "ss_decel",
        "rv_near_cm",
        "he_path_ms",
        "he_conf",
    }
    assert situation_constants({"rv_area": 99})["rv_area"] == 99
    with pytest.raises(ValueError, match="unknown situation parameter"):
        situation_constants({"nope": 1})


def test_overtaking_rule():
    flip = (
        "vehicle(1). vehicle(2). ra(1,2,7,before,after). ra(1,2,10,before,before). "
        "front(1,2,7). front(2,1,10)."
    )
    assert sit(flip, "overtaking") == [
        "info(overtaking,(1,2),nearer_until,frame(7))",
        "warn(overtaking,(1,2))",
    ]
    # oncoming: the overtaken vehicle approaches
    assert sit(flip + "motion(2,10,approaching).", "overtaking") == []
    # too long ago for ov_ms
    assert sit(flip, "overtaking", ov_ms=200) == []
    # one behind the other (x during): not side by side
    assert (
        sit(
            "vehicle(1). vehicle(2). ra(1,2,7,during,after). ra(1,2,10,during,before). "
            "front(1,2,7). front(2,1,10).",
            "overtaking",
        )
        == []
    )


def test_hidden_entity_rule():
    prog = (
        "person(1). vehicle(2). hidden_by(1,2,10). anticipated(1,2,18,600,250). "
        "anticipated_in_corridor(1,2,18)."
    )
    assert sit(prog, "hidden_entity") == [
        "info(hidden_entity,(1,2),reappear_frame,frame(18))",
        "warn(hidden_entity,(1,2))",
    ]
    assert sit(prog, "hidden_entity", he_lead_ms=500) == []
    assert sit(prog.replace("anticipated_in_corridor(1,2,18).", ""), "hidden_entity") == []


def test_hidden_entity_hiding_confidence():
    """The latest hiding of T behind O gives the confidence; below he_conf, no warning."""
    prog = (
        "person(1). vehicle(2). vehicle(3). hidden_by(1,2,10). anticipated(1,2,18,600,250). "
        "anticipated_in_corridor(1,2,18). confidence_at(hides_behind(1,2),4,750). "
        "confidence_at(may_hide_behind(1,2),9,250). confidence_at(hides_behind(1,3),10,1000)."
    )
    assert "info(hidden_entity,(1,2),confidence_permille,250)" in sit(prog, "hidden_entity")
    assert sit(prog, "hidden_entity", he_conf=250) == sit(prog, "hidden_entity")
    assert sit(prog, "hidden_entity", he_conf=251) == []
    # the earlier, surer hiding is the latest once the late one is gone
    sure = prog.replace("confidence_at(may_hide_behind(1,2),9,250).", "")
    assert "info(hidden_entity,(1,2),confidence_permille,750)" in sit(
        sure, "hidden_entity", he_conf=500
    )
    # no hiding event in the window: no confidence, not ruled out
    bare = (
        "person(1). vehicle(2). hidden_by(1,2,10). anticipated(1,2,18,600,250). "
        "anticipated_in_corridor(1,2,18)."
    )
    assert sit(bare, "hidden_entity", he_conf=900) == [
        "info(hidden_entity,(1,2),reappear_frame,frame(18))",
        "warn(hidden_entity,(1,2))",
    ]


def test_reduced_visibility_rule():
    big = "vehicle(3). in_corridor(3,10). state(3,10,visible). area(3,10,200)."
    assert sit(big, "reduced_visibility") == [
        "info(reduced_visibility,(3,),area_permille,200)",
        "warn(reduced_visibility,(3,))",
    ]
    assert sit(big, "reduced_visibility", rv_area=300) == []
    hides = "in_corridor(3,10). state(3,10,visible). area(3,10,20). hidden_by(5,3,10)."
    assert sit(hides, "reduced_visibility") == [
        "info(reduced_visibility,(3,),area_permille,20)",
        "info(reduced_visibility,(3,),hides,track(5))",
        "warn(reduced_visibility,(3,))",
    ]


def test_sudden_stop_rule():
    front = "vehicle(4). in_corridor(4,10). area(4,10,40). "
    assert sit(front + "motion(4,10,stopping).", "sudden_stop") == [
        "info(sudden_stop,(4,),cause,stopping)",
        "warn(sudden_stop,(4,))",
    ]
    # looming right after keeping its distance: the vehicle ahead brakes
    assert sit(front + "motion(4,10,looming). motion(4,8,keeping_distance).", "sudden_stop") == [
        "info(sudden_stop,(4,),cause,looming)",
        "warn(sudden_stop,(4,))",
    ]
    # looming all along (a parked car the ego drives towards): no sudden stop
    assert sit(front + "motion(4,10,looming). motion(4,8,looming).", "sudden_stop") == []
    assert sit(front + "motion(4,10,stopping).", "sudden_stop", ss_area=50) == []


def test_blocked_lane_rule():
    stopped = " ".join(f"motion(6,{f},stopped)." for f in range(6, 11))
    prog = f"lane(1). on_lane(6,1,10). {stopped}"
    assert sit(prog, "blocked_lane") == [
        "info(blocked_lane,(6,),lane,1)",
        "warn(blocked_lane,(6,))",
    ]
    assert (
        sit(
            prog.replace("motion(6,6,stopped).", "").replace("motion(6,7,stopped).", ""),
            "blocked_lane",
        )
        == []
    )
    assert sit(prog + "surface(6,10,sidewalk).", "blocked_lane") == []
    assert sit(prog + "surface(6,10,road).", "blocked_lane") == [
        "info(blocked_lane,(6,),lane,1)",
        "warn(blocked_lane,(6,))",
    ]


def test_exiting_vehicle_rule():
    prog = (
        "person(7). vehicle(8). occurs_at(starts(7),8). ra(7,8,9,overlaps,finishes). "
        "motion(8,9,stopped)."
    )
    assert sit(prog, "exiting_vehicle") == [
        "info(exiting_vehicle,(7,8),appeared,frame(8))",
        "warn(exiting_vehicle,(7,8))",
    ]
    assert sit(prog.replace("starts(7),8", "starts(7),0"), "exiting_vehicle") == []  # first frame
    assert (
        sit(prog.replace("overlaps,finishes", "before,finishes"), "exiting_vehicle") == []
    )  # apart
    assert sit(prog.replace("motion(8,9,stopped).", ""), "exiting_vehicle") == []  # moving vehicle


def test_solver_caches_clingo_answers_by_facts_and_uses_only_the_parts_asked_for(tmp_path):
    big = "vehicle(3). in_corridor(3,10). state(3,10,visible). area(3,10,200)."
    facts = _facts(big)
    solver = SituationSolver(["reduced_visibility"])
    first = solver.answer(facts)
    assert solver.answer(facts) == first and (solver.calls, solver.hits) == (1, 1)
    assert SituationSolver(["overtaking"]).answer(facts) == ()
    extra = tmp_path / "front.lp"
    extra.write_text("warn(big_front,(T,)) :- now(N), area(T,N,A), A > 100.")
    got = SituationSolver([], extra_encodings=[extra]).answer(facts)
    assert [str(s) for s in got] == ["warn(big_front,(3,))"]
