"""The ride's domain prior for :class:`~spotfree.learner.SetSupervisedLearner`: braking loses speed, a turn yaws.

A ride model asks for it by name (``spotfree train --prior ride``); the generic learner never uses it by itself.

Declared sets cannot tell cruising from normal braking when every ride holds both (a rider slows down now and then on
any ride); the GPS speed can. Around each window's centre the speed's trend ``a`` (m/s^2) is the least-squares slope
of the GPS fixes within ``SPAN`` s (:func:`speed_trend`). A window that loses speed (``a <= -slowing``) is more likely
braking, one that keeps or gains it more likely not:

    log prior(c) += weight   if c is a braking class and a <= -slowing, or c is not braking and a > -slowing

Declared sets can tell a turn from straight riding, but not where it starts and ends: a window that holds a little of
a turn looks like none of the straight rides, so the turn claims the straight riding next to it. The yaw rate says
where the vehicle turns. With ``y`` the largest ``|yaw_rate|`` (rad/s) within ``bridge`` s of the window's centre
(which carries a slalom across the instants its yaw rate passes through zero between two lobes):

    log prior(c) += weight   if c is a turning class and y >= yawing, or c is not turning and y < yawing

Each part engages only for the classes it names (``braking``, ``turning``) and only in recordings that carry its
channel (``speed``, ``yaw_rate``), and only where that channel has a value: for any other data the prior is zero.
Which classes those are is what each class is to the prior, its role (:data:`ROLES`), not its spelling: a preset
gives its own classes their roles (:data:`spotfree.presets.PRESET_ROLES`), a user gives theirs
(``spotfree train --role CLASS=ROLE``), and :func:`with_roles` makes the prior of a training from both, with a
warning for each declared class whose role neither gives.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.ndimage


ROLES = {"slowing": "loses GPS speed: a braking, a stop", "turn": "yaws: a turn, a slalom",
         "none": "neither: cruising, straight riding, a road surface"}
"""What a class can be to :class:`RidePrior`: its ``slowing`` classes are ``braking``, its ``turn`` classes
``turning``."""

SPAN = 1.5
"""Half-width (s) of the stretch of GPS fixes the speed trend is fitted over (three fixes of a 1 Hz receiver)."""


def speed_trend(speed: np.ndarray, rate: float, at: np.ndarray, span: float = SPAN) -> np.ndarray:
    """Least-squares slope (m/s^2) of the GPS ``speed`` (m/s, NaN between fixes, sampled at ``rate`` Hz) over the
    fixes within ``span`` s of each sample index ``at``; NaN where fewer than two fixes lie there. With the ``n``
    fixes ``(t_i, v_i)`` there: ``(n S_tv - S_t S_v) / (n S_tt - S_t^2)``, each sum a difference of cumulative sums."""
    fix = np.flatnonzero(np.isfinite(speed))
    t, v = fix / rate, speed[fix]
    sums = [np.r_[0.0, np.cumsum(x)] for x in (np.ones_like(t), t, v, t * t, t * v)]
    centre = np.asarray(at) / rate
    lo, hi = np.searchsorted(t, centre - span), np.searchsorted(t, centre + span, side="right")
    n, s_t, s_v, s_tt, s_tv = (c[hi] - c[lo] for c in sums)
    denominator = n * s_tt - s_t ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where((n >= 2) & (denominator > 1e-9), (n * s_tv - s_t * s_v) / denominator, np.nan)


@dataclass(frozen=True)
class RidePrior:
    """Braking loses speed, a turn yaws (module docstring).

    Parameters
    ----------
    braking : tuple of str
        The classes that lose speed.
    slowing : float
        Deceleration (m/s^2) from which a window counts as losing speed.
    turning : tuple of str
        The classes during which the vehicle turns.
    yawing : float
        Yaw rate (rad/s, either side) from which a window counts as turning.
    bridge : float
        Half-width (s) of the stretch around a window's centre whose largest yaw rate is compared with ``yawing``.
    weight : float
        Log-prior bonus of the classes that agree with the speed's trend, and of those that agree with the yaw rate.
    """

    braking: tuple[str, ...] = ("normal-braking", "sudden-braking")
    slowing: float = 0.4
    turning: tuple[str, ...] = ("gentle-turn", "sharp-turn", "slalom")
    yawing: float = 0.1
    bridge: float = 0.25
    weight: float = 2.0

    def log_prior(self, recording, centres: np.ndarray, classes: list[str]) -> np.ndarray:
        """``(len(centres), len(classes))`` log-prior of the windows centred at sample indices ``centres`` of
        ``recording``."""
        centres = np.asarray(centres)
        out = np.zeros((len(centres), len(classes)))
        braking = np.isin(classes, self.braking)
        if "speed" in recording.channels and braking.any():
            trend = speed_trend(np.asarray(recording.channels["speed"], dtype=float), recording.rate, centres)
            self._agree(out, braking, np.isfinite(trend), trend <= -self.slowing)
        turning = np.isin(classes, self.turning)
        if "yaw_rate" in recording.channels and turning.any():
            yaw = np.abs(np.asarray(recording.channels["yaw_rate"], dtype=float))
            reach = int(round(self.bridge * recording.rate))
            peak = scipy.ndimage.maximum_filter1d(np.nan_to_num(yaw, nan=-1.0), 2 * reach + 1, mode="nearest")
            self._agree(out, turning, np.isfinite(yaw[centres]), peak[centres] >= self.yawing)
        return out

    def _agree(self, out: np.ndarray, named: np.ndarray, known: np.ndarray, holds: np.ndarray) -> None:
        """Add ``weight`` to the ``named`` classes where ``holds`` and to the others where it does not, in the rows
        that are ``known``."""
        out[(known & holds)[:, None] & named[None, :]] += self.weight
        out[(known & ~holds)[:, None] & ~named[None, :]] += self.weight


def with_roles(prior: RidePrior, classes, known: dict[str, str], given: dict[str, str]) -> tuple[RidePrior, list[str]]:
    """``prior`` for a training on the declared ``classes``, each class's role (:data:`ROLES`) taken from ``given``
    (the user's), else ``known`` (a preset's, :data:`spotfree.presets.PRESET_ROLES`), else ``prior``'s own names;
    and one warning, naming the classes of no role and what to do, when there are any (the prior takes them as
    neither slowing nor turning).

    A ``slowing`` class joins ``braking`` and leaves ``turning``, a ``turn`` class the other way round, a ``none``
    class leaves both; ``prior``'s other names stay, so a training on a preset's own classes gets ``prior`` itself.
    """
    role = {c: given.get(c) or known.get(c) or ("slowing" if c in prior.braking else "turn" if c in prior.turning
                                                else None) for c in classes}
    braking = [c for c in prior.braking if role.get(c, "slowing") == "slowing"]
    turning = [c for c in prior.turning if role.get(c, "turn") == "turn"]
    braking += [c for c in classes if role[c] == "slowing" and c not in braking]
    turning += [c for c in classes if role[c] == "turn" and c not in turning]
    if (braking, turning) != (list(prior.braking), list(prior.turning)):
        prior = replace(prior, braking=tuple(braking), turning=tuple(turning))
    unknown = [c for c in classes if role[c] is None]
    if not unknown:
        return prior, []
    one = len(unknown) == 1
    idle = "" if any(role[c] in ("slowing", "turn") for c in classes) else "; it engages for no class of this training"
    return prior, [f"the ride prior does not know what class{'' if one else 'es'} {', '.join(map(repr, unknown))} "
                   f"{'is' if one else 'are'} and takes {'it' if one else 'them'} as neither slowing nor turning{idle}; "
                   f"give {'it' if one else 'each'} a role: --role {unknown[0]}=slowing (loses GPS speed: a braking, "
                   f"a stop), --role {unknown[0]}=turn (yaws) or --role {unknown[0]}=none"]
