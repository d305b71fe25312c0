"""Readers and writers of sensor logs; every reader returns a :class:`~spotfree.io.recording.Recording`."""

from spotfree.io.recording import Gap, Recording

__all__ = ["Gap", "Recording"]
