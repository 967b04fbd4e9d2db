"""Readers and writers for the formats people have (MOTChallenge, KITTI tracking).

:mod:`~sensemaking.io.mot`, :mod:`~sensemaking.io.kitti` (whole files),
:mod:`~sensemaking.io.formats` (by format name), :mod:`~sensemaking.io.stream` (detections frame
by frame, bounded memory), :mod:`~sensemaking.io.tables` (the text-table parsing they share),
:mod:`~sensemaking.io.media` (image folders and videos), :mod:`~sensemaking.io.atomic`
(whole-or-nothing files). The pipeline's output sinks are :mod:`sensemaking.sinks` (they write
what the reasoning layer makes; nothing here imports it).
"""
