"""The offline votes of a model (:mod:`spotfree.votes.segments`) as options, checked against the model, run on its
labels, and stored in its file.

:class:`Votes` holds the options of one model: the segment vote's penalty, the classes the votes keep, the event
vote's background class and the event edges (``spotfree classify --segments --keep --events --edges``). They run on
labels made without them (:func:`apply_votes`), per gap-free stretch, in that order; being offline, by default on the
centred labels (:func:`voted_labels`, :func:`voted_models`). Their settings are chosen per
model by whoever trained it, who may store them in the model file, ``parameters["votes"]`` of
:class:`~spotfree.model.DictionaryModel` (JSON: ``{"segments": P, "keep": [CLASS...], "events": [CLASS], "edges":
{CHANNEL: LEVEL}}``, checked against the model when stored), so that whoever labels with the model need not know
them (``spotfree votes``, ``spotfree classify --offline``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from spotfree.classify.batch import Labels, classifiable_features, classify_recording
from spotfree.classify.multi import label_table, model_labels, shared_features
from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.votes.segments import change_points, event_edges, event_ends, segment_signal, segment_vote


@dataclass(frozen=True)
class Votes:
    """The offline votes to run on one model's labels; the default runs none.

    Parameters
    ----------
    segments : float or None
        Penalty of the segment vote, in units of the standardised squared error per segment; None or 0: no
        segment vote.
    keep : tuple of str
        Classes the segment and event votes leave as labelled (short events such as ``kerb``).
    events : tuple of str
        The model's background class (at most one of these may be a class of the model): the event vote runs after
        the segment vote; empty: none.
    edges : mapping of str to float
        ``{channel: level}`` (the channel's units) for one of the model's channels: the event edges after the event
        vote, each moved by at most one window; empty: none.
    """

    segments: float | None = None
    keep: tuple[str, ...] = ()
    events: tuple[str, ...] = ()
    edges: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "keep", tuple(self.keep))
        object.__setattr__(self, "events", tuple(self.events))
        object.__setattr__(self, "edges", dict(self.edges or {}))

    def plan(self, model: DictionaryModel) -> tuple:
        """``(penalty, keep, background, edge)`` checked against ``model``: the segment penalty (None: no segment
        vote), the kept classes, the event vote's background class (None: no event vote) and the event edge
        ``(channel, level)`` (None: none)."""
        penalty = check_penalty(self.segments)
        check_classes("--keep", self.keep, model.classes)
        check_classes("--events", self.events, model.classes)
        background = event_background(self.events, model.classes)
        return penalty, self.keep, background, model_edge(self.edges, model.channels, background)


def check_penalty(penalty: float | None) -> float | None:
    """``penalty`` validated: None or 0 means no segment vote."""
    if penalty is None or penalty == 0:
        return None
    if isinstance(penalty, bool) or not isinstance(penalty, (int, float, np.integer, np.floating)) \
            or not np.isfinite(penalty) or penalty < 0:
        raise InputError(f"segment penalty (--segments) must be a number > 0 (or 0 for none), got {penalty!r}")
    return float(penalty)


def check_classes(option: str, names: Iterable[str], classes: Iterable, whose: str = "the model") -> None:
    """Refuse the class ``names`` given to ``option`` (``--keep``, ``--events``) that are not among ``classes``
    (those of ``whose``)."""
    _refuse_unknown(option, names, classes, "class", whose)


def check_channels(option: str, names: Iterable[str], channels: Iterable, whose: str = "the model") -> None:
    """Refuse the channel ``names`` given to ``option`` (``--edges``) that are not among ``channels``."""
    _refuse_unknown(option, names, channels, "channel", whose)


def _refuse_unknown(option: str, names: Iterable[str], known: Iterable, kind: str, whose: str) -> None:
    known = sorted({str(c) for c in known})
    unknown = sorted(set(names) - set(known))
    if unknown:
        raise InputError(f"{option} {', '.join(unknown)}: not a {kind} of {whose} ({', '.join(known)})")


def kept_classes(keep: Iterable[str], classes: Iterable) -> tuple[str, ...]:
    """The classes of ``keep`` that are among a model's ``classes``."""
    names = {str(c) for c in classes}
    return tuple(c for c in keep if c in names)


def event_background(events: Iterable[str], classes: Iterable) -> str | None:
    """The one class of ``events`` (background classes given for the event vote) that is among a model's
    ``classes``; None when there is none."""
    found = kept_classes(events, classes)
    if len(found) > 1:
        raise InputError(f"--events {', '.join(found)}: give one background class per model")
    return found[0] if found else None


def edge_levels(values: Iterable[str]) -> dict[str, float]:
    """``--edges CHANNEL=LEVEL`` values as ``{channel: level}``; a level must be a number > 0 (channel units)."""
    levels = {}
    for value in values:
        channel, _, number = str(value).partition("=")
        try:
            level = float(number)
        except ValueError:
            level = math.nan
        if not channel or not math.isfinite(level) or level <= 0:
            raise InputError(f"--edges {value}: give CHANNEL=LEVEL, a channel of the model and a level > 0 in its "
                             "units (yaw_rate=0.09 for the lateral model)")
        levels[channel] = level
    return levels


def model_edge(edges: Mapping[str, float], channels: Iterable[str], background: str | None,
               whose: str = "the model") -> tuple[str, float] | None:
    """The ``(channel, level)`` of ``edges`` (:func:`edge_levels`) for a model with these ``channels`` and event-vote
    ``background`` class, or None when ``edges`` is empty; refused when it names another channel, more than one,
    or the model runs no event vote."""
    if not edges:
        return None
    check_channels("--edges", edges, channels, whose)
    if len(edges) > 1:
        raise InputError(f"--edges {', '.join(edges)}: give one channel per model ({whose})")
    if background is None:
        raise InputError(f"--edges {next(iter(edges))}: {whose} runs no event vote; give its background class "
                         "with --events")
    return next(iter(edges.items()))


def apply_votes(model: DictionaryModel, rec: Recording, labels: Labels, votes: Votes) -> Labels:
    """``labels`` (made by :func:`~spotfree.classify.batch.classify_recording` from ``model`` and ``rec``, without
    votes) after ``votes``, each per gap-free stretch; ``labels`` itself when ``votes`` runs none. The result's
    ``meta`` adds ``segments`` (the penalty, 0 for none), ``keep``, ``events`` (the background class, ``""`` for
    none) and ``edges`` (``{channel: level}``, empty for none)."""
    if len(labels) != len(rec) or "segments" in labels.meta:
        raise InputError(f"{rec.source}: offline votes need the labels of this recording made without votes")
    penalty, keep, background, edge = votes.plan(model)
    if not (penalty or background):
        return labels
    feats = classifiable_features(model, rec)
    label = np.asarray(labels.label, dtype=object).copy()
    for start, stop in feats.segments():
        if penalty:
            x = segment_signal({c: feats.channels[c][start:stop] for c in model.channels}, model.channels)
            label[start:stop] = segment_vote(label[start:stop], change_points(x, penalty), keep)
        if background:
            label[start:stop] = segment_vote(label[start:stop], event_ends(label[start:stop], background), keep)
        if edge:
            label[start:stop] = event_edges(label[start:stop], feats.channels[edge[0]][start:stop], background,
                                            edge[1], model.window)
    meta = dict(labels.meta, segments=penalty or 0, keep=list(keep), events=background or "",
                edges=dict([edge]) if edge else {})
    return replace(labels, label=label, meta=meta)


def voted_labels(model: DictionaryModel, rec: Recording, votes: Votes, centred: bool = True, **options) -> Labels:
    """:func:`~spotfree.classify.batch.classify_recording` of ``rec`` by ``model`` (``centred`` windows by default,
    the offline labels; ``options``: its other keyword arguments) after :func:`apply_votes`; the votes are checked
    first and the features computed once."""
    votes.plan(model)
    feats = classifiable_features(model, rec)
    return apply_votes(model, feats, classify_recording(model, feats, centred=centred, **options), votes)


def votes_per_model(models: Mapping[str, DictionaryModel], segments: float | Mapping[str, float] | None = None,
                    keep: Iterable[str] = (), events: Iterable[str] = (),
                    edges: Mapping[str, float] | None = None) -> dict[str, Votes]:
    """The :class:`Votes` of each model (by name) from options given for all of them: ``segments`` one penalty for
    all or one per model name (none for a model it does not name); each model keeps the classes of ``keep`` it has,
    runs the event vote when one of ``events`` is its class, and then its event edges when one of ``edges``
    (``{channel: level}``) is its channel. A class or channel that no model has is refused."""
    keep, events, edges = tuple(keep), tuple(events), dict(edges or {})
    check_classes("--keep", keep, [c for model in models.values() for c in model.classes], "any model")
    check_classes("--events", events, [c for model in models.values() for c in model.classes], "any model")
    check_channels("--edges", edges, [c for model in models.values() for c in model.channels], "any model")
    votes = {}
    for name, model in models.items():
        own_edges = {c: level for c, level in edges.items() if c in model.channels}
        model_edge(own_edges, model.channels, event_background(events, model.classes), f"model {name}")
        votes[name] = Votes(segments.get(name) if isinstance(segments, Mapping) else segments,
                            kept_classes(keep, model.classes), kept_classes(events, model.classes), own_edges)
    return votes


def voted_models(models: Mapping[str, DictionaryModel], rec: Recording, votes: Mapping[str, Votes],
                 centred: bool = True, **options) -> pd.DataFrame:
    """:func:`~spotfree.classify.multi.classify_models` of ``rec`` (``centred`` windows by default, the offline
    labels; ``options``: its other keyword arguments) with each model's labels after its ``votes`` (by name; a model
    not named runs none); one feature pass."""
    for name, model in models.items():
        votes.get(name, Votes()).plan(model)
    feats = shared_features(models, rec)
    labels = model_labels(models, feats, centred=centred, **options)
    return label_table({name: apply_votes(models[name], feats, labels[name], votes.get(name, Votes()))
                        for name in models})


def model_penalties(values: Iterable[str], names: list[str]) -> dict[str, float]:
    """Segment-vote penalty per model name from ``--segments`` values: ``P`` for every model, ``NAME=P`` for the
    model named ``NAME`` (it wins over ``P``); 0 (no vote) where none is given. The numbers are checked where the
    vote runs (:func:`check_penalty`)."""
    default, own = 0.0, {}
    for value in values:
        name, _, number = str(value).rpartition("=")
        try:
            penalty = float(number)
        except ValueError:
            raise InputError(f"--segments {value}: give a penalty (a number) or MODEL=PENALTY, MODEL one of "
                             f"{', '.join(names)}") from None
        if name and name not in names:
            raise InputError(f"--segments {value}: no model is named {name} (models: {', '.join(names)})")
        if name:
            own[name] = penalty
        else:
            default = penalty
    return {name: own.get(name, default) for name in names}


def stored_votes(model: DictionaryModel) -> Votes:
    """The offline votes stored in ``model`` (none where it stores none)."""
    votes = model.parameters.get("votes") or {}
    return Votes(votes.get("segments"), votes.get("keep", ()), votes.get("events", ()), votes.get("edges", {}))


def with_votes(model: DictionaryModel, votes: Votes = Votes()) -> DictionaryModel:
    """A copy of ``model`` storing ``votes`` (all of them replaced; the default: no stored vote), checked against
    the model as :func:`apply_votes` checks them."""
    penalty = votes.plan(model)[0]
    stored = {"segments": penalty, "keep": list(votes.keep), "events": list(votes.events), "edges": dict(votes.edges)}
    stored = {k: v for k, v in stored.items() if v}
    parameters = {k: v for k, v in model.parameters.items() if k != "votes"} | ({"votes": stored} if stored else {})
    return replace(model, parameters=parameters)


def describe(votes: Votes) -> str:
    """``votes`` in the words of ``classify``'s options (``--segments P --keep C --events C --edges CHANNEL=LEVEL``);
    "" for none."""
    words = ([f"--segments {votes.segments:g}"] if votes.segments else []) \
        + [f"--keep {c}" for c in votes.keep] + [f"--events {c}" for c in votes.events] \
        + [f"--edges {c}={level:g}" for c, level in votes.edges.items()]
    return " ".join(words)
