"""The ride's domain prior for :class:`~spotfree.learner.SetSupervisedLearner`: braking loses speed.

A ride model asks for it by name (``spotfree train --prior ride``); the generic learner never uses it by itself.

Declared sets cannot tell cruising from normal braking when every ride holds both (a rider slows down now and then on
any ride); the GPS speed can. Around each window's centre the speed's trend ``a`` (m/s^2) is the least-squares slope
of the GPS fixes within ``SPAN`` s (:func:`speed_trend`). A window that loses speed (``a <= -slowing``) is more likely
braking, one that keeps or gains it more likely not:

    log prior(c) = +weight   if c is a braking class and a <= -slowing, or c is not braking and a > -slowing
                   0         otherwise, and for every class where the recording has no GPS speed

The prior engages only for the classes it names (``braking``) and only in recordings that carry a ``speed`` channel:
for any other data it is zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
    """Braking loses speed (module docstring).

    Parameters
    ----------
    braking : tuple of str
        The classes that lose speed.
    slowing : float
        Deceleration (m/s^2) from which a window counts as losing speed.
    weight : float
        Log-prior bonus of the classes that agree with the speed's trend.
    """

    braking: tuple[str, ...] = ("normal-braking", "sudden-braking")
    slowing: float = 0.4
    weight: float = 2.0

    def log_prior(self, recording, centres: np.ndarray, classes: list[str]) -> np.ndarray:
        """``(len(centres), len(classes))`` log-prior of the windows centred at sample indices ``centres`` of
        ``recording``."""
        out = np.zeros((len(centres), len(classes)))
        named = np.isin(classes, self.braking)
        if "speed" not in recording.channels or not named.any():
            return out
        trend = speed_trend(np.asarray(recording.channels["speed"], dtype=float), recording.rate,
                            np.asarray(centres))
        known = np.isfinite(trend)
        slowing = known & (trend <= -self.slowing)
        out[slowing[:, None] & named[None, :]] = self.weight
        out[(known & ~slowing)[:, None] & ~named[None, :]] = self.weight
        return out

