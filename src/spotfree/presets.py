"""Named learner settings of spotfree's ride models: the channels, window, representation and prior each model asks
for, so that the same model can be trained again on one's own rides with one command
(``spotfree train --preset NAME``) or in Python (:func:`preset_learner`).

``braking``
    Cruising, normal and sudden braking: the paper's block-Hankel windows (1 s at 20 Hz) of the speed-aided
    longitudinal acceleration and the pitch rate, with the ride prior (:class:`~spotfree.ride_prior.RidePrior`:
    braking loses GPS speed).
``lateral``
    Straight riding, gentle and sharp turns, slaloms: summary windows (2 s) of the yaw rate, with the ride prior (a
    turn yaws, which places a turn's start and end in the names). A slalom's lobes last 1-2 s, so a window of 1 s
    often holds one lobe alone, which looks like part of a turn; one of 2 s mostly holds a change of direction.
``road``
    Smooth road, rough asphalt, cobblestone, kerb strikes: summary windows (0.5 s) of the speed-normalised
    vibration ``rough_y, rough_z``.

Each preset also says from how many of a class's windows its columns are drawn (``column_share`` of
:class:`~spotfree.learner.SetSupervisedLearner`). The lateral and road models draw from every window of a class: their
training rides each hold one kind of manoeuvre or surface beside the straight, smooth riding that other rides hold
alone, which names the windows well, and the dictionary then also holds a class's less typical windows (a slow,
shallow slalom). The braking model draws from three quarters of a class's windows: sudden braking is declared in a
single ride and claims more than itself there, which every window would let into its columns.

The lateral model also keeps up to 3,000 columns per class (``max_columns``; 300 by default): its straight riding
spans many more windows than its turns, and a few hundred spread evenly over it hold few of the windows just after a
turn, which the live labels get wrong most. With its names sure, more of them serve; where names are less sure,
more columns also let in more wrong ones.

A preset fixes only these eight settings; every other parameter of
:class:`~spotfree.learner.SetSupervisedLearner` keeps its default unless given.
"""

from __future__ import annotations

from spotfree.errors import InputError
from spotfree.learner import SetSupervisedLearner
from spotfree.ride_prior import RidePrior

PRIORS = {"ride": RidePrior}
"""Domain priors a model may ask for by name (``spotfree train --prior NAME``)."""

PRESETS = {
    "braking": {"channels": ("acc_long", "pitch_rate"), "window": 20, "representation": "hankel", "prior": "ride",
                "column_share": 0.75, "max_columns": 300, "share_power": 0.5, "smoothing": 0.5},
    "lateral": {"channels": ("yaw_rate",), "window": 40, "representation": "summary", "prior": "ride",
                "column_share": 1.0, "max_columns": 3000, "share_power": 0.5, "smoothing": 0.5},
    "road": {"channels": ("rough_y", "rough_z"), "window": 10, "representation": "summary", "prior": None,
             "column_share": 1.0, "max_columns": 300, "share_power": 0.5, "smoothing": 0.5},
}
"""Per preset: channels, window (samples at 20 Hz), representation, prior name, column share, most columns per
class, share power and smoothing (module docstring). A preset fixes every setting the learner would otherwise choose
(:data:`~spotfree.learner.SELECTED`); one of them given as None is chosen again."""

PRESET_ROLES = {
    "braking": {"cruising": "none", "normal-braking": "slowing", "sudden-braking": "slowing"},
    "lateral": {"straight": "none", "gentle-turn": "turn", "sharp-turn": "turn", "slalom": "turn"},
    "road": {"smooth": "none", "rough-asphalt": "none", "cobblestone": "none", "kerb": "none"},
}
"""Per preset, what each of its classes is to the ride prior (:data:`spotfree.ride_prior.ROLES`): a user's class
of another name is given its role with ``spotfree train --role CLASS=ROLE``
(:func:`spotfree.ride_prior.with_roles`)."""


def prior_named(name: str | None):
    """A fresh prior of :data:`PRIORS` by name; None for None."""
    if name is None:
        return None
    if name not in PRIORS:
        raise InputError(f"prior {name!r} is unknown; use one of {', '.join(PRIORS)}")
    return PRIORS[name]()


def prior_name(prior) -> str | None:
    """The name (:data:`PRIORS`) a fitted or fresh ``prior`` is asked for by; None for None."""
    return None if prior is None else next(name for name, kind in PRIORS.items() if isinstance(prior, kind))


def preset_learner(name: str, **params) -> SetSupervisedLearner:
    """The learner of preset ``name`` (:data:`PRESETS`); ``params`` override any parameter of
    :class:`~spotfree.learner.SetSupervisedLearner`."""
    if name not in PRESETS:
        raise InputError(f"preset {name!r} is unknown; use one of {', '.join(PRESETS)}")
    settings = {**PRESETS[name], "prior": prior_named(PRESETS[name]["prior"])}
    return SetSupervisedLearner(**{**settings, **params})
