"""A model's offline votes, stored in its file (``spotfree votes``) and used by ``spotfree classify --offline``.

The votes of :mod:`spotfree.classify.segments` have settings chosen per model by measurement (the lateral model:
penalty 4, the event vote outside ``straight``, edges at ``yaw_rate`` 0.09 rad/s). Whoever chose them stores them in
the model file, ``parameters["votes"]`` of :class:`~spotfree.model.DictionaryModel` (JSON), so that whoever
labels with the model need not know them: ``{"segments": P, "keep": [CLASS...], "events": [CLASS],
"edges": {CHANNEL: LEVEL}}``, each checked against the model when stored.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import replace

from spotfree.classify.batch import vote_options
from spotfree.model import DictionaryModel


def stored_votes(model: DictionaryModel) -> dict:
    """The offline votes stored in ``model`` as options of :func:`~spotfree.classify.batch.classify_recording`
    (no vote where it stores none)."""
    votes = model.parameters.get("votes") or {}
    return {"segments": votes.get("segments"), "keep": tuple(votes.get("keep", ())),
            "events": tuple(votes.get("events", ())), "edges": dict(votes.get("edges", {}))}


def with_votes(model: DictionaryModel, segments: float | None = None, keep: Iterable[str] = (),
               events: Iterable[str] = (), edges: Mapping[str, float] | None = None) -> DictionaryModel:
    """A copy of ``model`` storing these votes (all of them replaced; none given: no stored vote), each checked
    against the model as :func:`~spotfree.classify.batch.classify_recording` checks it."""
    keep, events, edges = tuple(keep), tuple(events), dict(edges or {})
    penalty = vote_options(model, segments, keep, events, edges)[0]
    votes = {"segments": penalty, "keep": list(keep), "events": list(events), "edges": edges}
    stored = {k: v for k, v in votes.items() if v}
    parameters = {k: v for k, v in model.parameters.items() if k != "votes"} | ({"votes": stored} if stored else {})
    return replace(model, parameters=parameters)


def describe(votes: Mapping) -> str:
    """The votes (options of :func:`~spotfree.classify.batch.classify_recording`) in the words of ``classify``'s
    options: ``--segments 4 --events straight --edges yaw_rate=0.09``; "" for none."""
    words = ([f"--segments {votes['segments']:g}"] if votes.get("segments") else []) \
        + [f"--keep {c}" for c in votes.get("keep", ())] + [f"--events {c}" for c in votes.get("events", ())] \
        + [f"--edges {c}={level:g}" for c, level in votes.get("edges", {}).items()]
    return " ".join(words)
