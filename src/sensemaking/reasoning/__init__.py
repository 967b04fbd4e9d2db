"""Reasoning over tracker output: spatial relations, the scene's question answering,
anticipation of hidden objects, and online warnings about safety-critical situations.

Submodules (imported on demand, nothing happens at import time):

* :mod:`~sensemaking.reasoning.relations` -- interval / rectangle algebra, qualitative motion.
* :mod:`~sensemaking.reasoning.context` -- ego corridor, lanes, semantic segmentation.
* :mod:`~sensemaking.reasoning.questions` -- ``ask(scene, query)`` and ``explain(scene)``.
* :mod:`~sensemaking.reasoning.anticipation` -- where and when a hidden object reappears.
* :mod:`~sensemaking.reasoning.situations` -- the situation encoding, ``SituationWarning``.
* :mod:`~sensemaking.reasoning.online` -- ``SituationMonitor.update(result) -> warnings``.
"""
