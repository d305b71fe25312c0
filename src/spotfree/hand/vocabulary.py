"""The hand's vocabulary: the postures that steer the wheelchair, the gestures between them, and the sessions of
the training protocol.

A gesture is the movement from one posture to another; every gesture starts or ends in ``straight``. A training
log holds, per person, one session per task of :data:`TRAINING_TASKS`, in that order, each starting in
``straight``:

* ``hold``: ``straight`` only (no gesture);
* ``out-X``: ``straight``, then ``X`` held to the end (the one gesture ``straight-to-X``);
* ``round-X``: round trips ``straight`` -> ``X`` -> ``straight`` (both gestures of ``X``).
"""

POSTURES = ("straight", "left", "right", "stop", "backward")
"""The five deictic postures (go straight, turn left, turn right, stop, go backward)."""

GESTURES = tuple(g for p in POSTURES[1:] for g in (f"straight-to-{p}", f"{p}-to-straight"))
"""The eight gestures: the movement from one posture to another."""

TRAINING_TASKS = ("hold", *(f"out-{p}" for p in POSTURES[1:]), *(f"round-{p}" for p in POSTURES[1:]))
"""The sessions of the training protocol of one person, in this order."""
