"""Wheelchair commands from the recognised hand postures, changed only once a new posture is confirmed.

Each posture maps to one command (:data:`COMMANDS`). The command stream starts at ``stop``; it changes to the
command of a posture only after the recogniser has labelled that posture for ``confirm`` seconds in a row
(``n = ceil(confirm * rate)`` consecutive samples in the posture state). A gesture holds the current command and
restarts the count; so does a sample with no label. A sample without a hand (no state: tracking lost, or the first
windows after it) gives ``stop`` at once: losing the hand must not leave the chair moving.

The latency of a command is the time from the true start of a posture (the end of the movement into it) to the
first sample at which the command of that posture is given: the recogniser's lag plus ``confirm``
(:func:`command_latencies`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from spotfree.errors import InputError

COMMANDS = {
    "straight": "go-straight", "left": "turn-left", "right": "turn-right", "stop": "stop", "backward": "go-backward",
}
"""Posture -> wheelchair command."""

SAFE = "stop"
"""The command without a hand, and before any posture is confirmed."""

CONFIRM = 0.25
"""s a new posture must be recognised without interruption before its command is given (5 samples at 20 Hz)."""


class CommandFilter:
    """The command stream of one session, one recognised sample at a time (rules in the module docstring)."""

    def __init__(self, rate: float, confirm: float = CONFIRM):
        if not confirm >= 0 or not rate > 0:
            raise InputError(f"confirmation time ({confirm} s) must be >= 0 and the rate ({rate} Hz) positive")
        self.rate = rate
        self.confirm = confirm
        self.needed = max(1, math.ceil(confirm * rate - 1e-9))
        self.reset()

    def reset(self) -> None:
        """A new session: ``stop``, nothing confirmed."""
        self.command = SAFE
        self._candidate = ""
        self._count = 0

    def update(self, state: str, label: str) -> str:
        """The command after a sample whose recognised ``state`` and ``label`` are given (``""``: none)."""
        if not state:
            self.command, self._candidate, self._count = SAFE, "", 0
            return self.command
        if state != "posture" or label not in COMMANDS:
            self._candidate, self._count = "", 0
            return self.command
        self._count = self._count + 1 if label == self._candidate else 1
        self._candidate = label
        if self._count >= self.needed:
            self.command = COMMANDS[label]
        return self.command


@dataclass
class CommandLatency:
    """Per posture onset ``time`` (s) of ``posture``: the ``latency`` (s) until its command, NaN when it never came
    during that hold."""

    time: np.ndarray
    posture: np.ndarray
    latency: np.ndarray

    def summary(self) -> dict[str, float]:
        """Count, share reached, median, 95th percentile and largest latency (s) of the onsets reached."""
        reached = self.latency[np.isfinite(self.latency)]
        return {
            "onsets": int(len(self.latency)),
            "reached": float(len(reached) / max(1, len(self.latency))),
            "median": float(np.median(reached)) if len(reached) else math.nan,
            "p95": float(np.percentile(reached, 95)) if len(reached) else math.nan,
            "max": float(reached.max()) if len(reached) else math.nan,
        }


def command_latencies(time: np.ndarray, command: np.ndarray, truth_state: np.ndarray,
                      truth_label: np.ndarray) -> CommandLatency:
    """Latency from each true posture onset that follows a gesture to its command (see the module docstring), in
    one session; ``truth_*`` are the ground truth per sample, for evaluation only."""
    posture = truth_state == "posture"
    onsets = np.flatnonzero(posture[1:] & (truth_state[:-1] == "gesture")) + 1
    times, names, latencies = [], [], []
    for onset in onsets:
        stop = onset
        while stop < len(posture) and posture[stop] and truth_label[stop] == truth_label[onset]:
            stop += 1
        given = np.flatnonzero(command[onset:stop] == COMMANDS[str(truth_label[onset])])
        times.append(time[onset])
        names.append(truth_label[onset])
        latencies.append(time[onset + given[0]] - time[onset] if len(given) else math.nan)
    return CommandLatency(np.array(times), np.array(names, dtype=str), np.array(latencies))
