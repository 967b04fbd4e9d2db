"""The strategy without abduction: plain Hungarian IoU matching, answered in the encoding's
vocabulary (the paper's "without abduction" ablation, and the fallback of a frame whose
abduction found no model within its budget).

It gates pairs as the abduction does (:func:`~sensemaking.abduction.observe.likelihood`) and
explains only what matching alone can tell: tracks start, end, go missing and reappear.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from sensemaking.abduction.observe import expired, likelihood
from sensemaking.abduction.solver import Answer, Det
from sensemaking.config import TrackerConfig
from sensemaking.detections import Detections
from sensemaking.track_table import TrackTable

__all__ = ["match_hungarian"]


def match_hungarian(
    tracks: TrackTable, pred: np.ndarray, dets: Detections, config: TrackerConfig
) -> Answer:
    """The frame's answer by Hungarian IoU matching of ``pred`` (T, 4) and ``dets`` with the
    same gates as the abduction; events only start / end / missing / reappear."""
    lik = likelihood(tracks, pred, dets, config)
    ans = Answer()
    matched_t: set[int] = set()
    matched_d: set[int] = set()
    if lik.size:
        rows, cols = linear_sum_assignment(-lik)
        for r, k in zip(rows.tolist(), cols.tolist(), strict=True):
            if lik[r, k] > 0:
                tid = int(tracks.id[r])
                (ans.assign if tracks.unseen[r] == 0 else ans.resume)[tid] = k
                matched_t.add(r)
                matched_d.add(k)
    ended = expired(tracks, config)
    for r in range(len(tracks)):
        if r in matched_t:
            if tracks.unseen[r] > 0:
                ans.events.append(("reappears", (int(tracks.id[r]),)))
            continue
        tid = int(tracks.id[r])
        if not tracks.confirmed[r] or ended[r]:
            ans.end.append(tid)
            ans.events.append(("ends", (tid,)))
        elif tracks.unseen[r] == 0:
            ans.halt.append(tid)
            ans.events.append(("missing_detections", (tid,)))
        else:
            ans.ignore_trk.append(tid)
    start_ok = dets.confidence >= config.class_gates(dets.class_id)[1]
    for k in range(len(dets)):
        if k in matched_d:
            continue
        if start_ok[k]:
            ans.start.append(k)
            ans.events.append(("starts", (Det(k),)))
        else:
            ans.ignore_det.append(k)
    return ans
