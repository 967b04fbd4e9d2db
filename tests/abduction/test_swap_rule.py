"""The identity-swap cost (``swap_weight``, issue 27, crossings traced): tracking.lp's rule on
tiny programs and the setting that feeds it."""

from __future__ import annotations

import pytest
from helpers import optimal

from sensemaking.config import ParameterError, TrackerConfig
from sensemaking.tracker import Tracker


def answer(facts: str, consts: dict[str, int] | None = None) -> list[str]:
    models = optimal(facts, consts)
    assert len(models) == 1, f"optimum not unique: {models}"
    return models[0][1]


# A crossing as traced on MOT17-02 (frame 196): track 0 is hidden behind track 1; the one
# detection left lies where 0 comes out, and fits 0's prediction (750) better than 1's (600).
CROSSING = (
    "track(0). ttype(0,1). halted(0). holds(in_fov(0),true,0). "
    "holds(hidden_by(0,1),true,0). holds(visibility(0),fully_occluded,0). "
    "track(1). ttype(1,1). active(1). holds(in_fov(1),true,0). "
    "holds(visibility(1),fully_visible,0). "
    "det(d(0),900). dtype(d(0),1). cand(0,d(0),750). cand(1,d(0),600). "
    "emerges(d(0),0). keeps_covering(d(0),0). "
)
ON = {"swap_weight": 400, "swap_margin": 100}


def test_off_the_occluder_keeps_the_detection_of_the_one_it_hid():
    # swap: 400 + 1000 (0 unmatched, still hidden) = 1400; the right one: resume 250 + 100,
    # 1 unmatched 1000, its detections missing 250 = 1600
    atoms = answer(CROSSING)
    assert "assign(1,d(0))" in atoms and "ignore_trk(0)" in atoms


def test_the_swap_cost_gives_the_detection_to_the_track_it_fits():
    atoms = answer(CROSSING, ON)
    assert "resume(0,d(0))" in atoms and "halt(1)" in atoms
    assert "occurs(unhides_from_behind(0,1))" in atoms
    # the optimum is the unswapped answer, 1600: the swap now costs 1400 + 400
    assert optimal(CROSSING, ON)[0][0] == 1600


def test_the_margin_and_the_weight_bound_the_rule():
    # 750 is not better than 600 by more than 150: no charge, the swap stays
    assert "assign(1,d(0))" in answer(CROSSING, {**ON, "swap_margin": 150})
    # 150 more is less than the 200 the swap saves
    assert "assign(1,d(0))" in answer(CROSSING, {**ON, "swap_weight": 150})
    # the taker fits better: nothing to charge
    better = CROSSING.replace("cand(1,d(0),600)", "cand(1,d(0),800)")
    assert "assign(1,d(0))" in answer(better, ON)


def test_a_tentative_unseen_track_does_not_count():
    tentative = CROSSING + "tentative(0). "
    # (dropping a tentative track is free: kept or dropped, the optimum is the swap's 1400)
    models = optimal(tentative, ON)
    assert {c for c, _ in models} == {1400}
    assert all("assign(1,d(0))" in atoms for _, atoms in models)


def test_swap_behind_counts_only_the_track_hidden_behind_the_taker():
    behind = {**ON, "swap_behind": 1}
    assert "resume(0,d(0))" in answer(CROSSING, behind)
    # missing, not hidden behind the taker: not counted with swap_behind
    other = CROSSING.replace("holds(hidden_by(0,1),true,0). ", "")
    other = other.replace("emerges(d(0),0). keeps_covering(d(0),0). ", "")
    assert "assign(1,d(0))" in answer(other, behind)
    # without swap_behind any unseen confirmed track counts
    assert "resume(0,d(0))" in answer(other, ON)


def test_the_setting_reaches_the_solver_only_when_on():
    config = TrackerConfig(swap_weight=400, swap_margin=0.1, swap_behind=True)
    constants = Tracker(config).solver.solver.constants
    assert constants["swap_weight"] == 400
    assert constants["swap_margin"] == 100
    assert constants["swap_behind"] == 1
    assert "swap_weight" not in Tracker().solver.solver.constants
    with pytest.raises(ParameterError, match="swap_weight must be in"):
        TrackerConfig(swap_weight=-1)
    with pytest.raises(ParameterError, match="swap_margin must be in"):
        TrackerConfig(swap_margin=1.5)
    assert TrackerConfig().swap_weight == 0
