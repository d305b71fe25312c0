"""Third-order Butterworth low-pass for the vehicle-frame accelerations (paper, section III).

Magnitude ``|H(f)|^2 = 1 / (1 + (f / f_c)^6)``. The cut-off ``f_c = 3 Hz`` (:data:`ACC_CUTOFF`) keeps what a braking
manoeuvre puts into the accelerations -- a Segway's deceleration builds up over 0.3 s or more, so its content
lies below about 2 Hz, where the gain is above 0.95 -- and removes handlebar vibration and sensor noise between
3 Hz and the 10 Hz Nyquist frequency of a 20 Hz log (-18 dB per octave). The causal filter delays slow signals
by its DC group delay ``2 / (2 pi f_c)`` = 0.11 s, about two samples at 20 Hz.

Designed by ``scipy.signal.butter(output='sos')``; applied causally by :func:`lowpass` (``sosfilt``) or
:class:`LowpassStream` (one sample at a time, explicit state), which agree to rounding, and offline without
phase lag by ``lowpass(..., zero_phase=True)`` (``sosfiltfilt``: magnitude squared, order 6 in effect).
Both causal forms start at rest on the first sample, so a constant input passes without a transient.
"""

from __future__ import annotations

import numpy as np
import scipy.signal

from spotfree.errors import InputError
from spotfree.signal.recursions import lowpass_step

ACC_CUTOFF = 3.0
"""Cut-off frequency of the acceleration low-pass, Hz."""
ACC_ORDER = 3
"""Order of the acceleration low-pass (the paper's third order)."""


def butter_lowpass(rate: float, cutoff: float = ACC_CUTOFF, order: int = ACC_ORDER) -> np.ndarray:
    """Second-order sections ``(order // 2 + 1, 6)`` of a Butterworth low-pass at ``cutoff`` Hz for ``rate`` Hz."""
    if not 0 < cutoff < rate / 2:
        raise InputError(
            f"Butterworth low-pass: cut-off {cutoff:g} Hz needs a sampling rate above {2 * cutoff:g} Hz, got "
            f"{rate:g} Hz; resample the log to 20 Hz"
        )
    return scipy.signal.butter(order, cutoff, btype="low", output="sos", fs=rate)


def lowpass(x: np.ndarray, sos: np.ndarray, zero_phase: bool = False) -> np.ndarray:
    """``x`` ``(n, m)`` filtered along time (axis 0): causal from rest on ``x[0]``, or zero-phase offline.

    The zero-phase form pads by odd extension of at most ``3 (2 sections + 1)`` samples (fewer on short input).
    """
    x = np.asarray(x, dtype=float)
    if len(x) == 0:
        return x.copy()
    if zero_phase:
        return scipy.signal.sosfiltfilt(sos, x, axis=0, padlen=min(3 * (2 * len(sos) + 1), len(x) - 1))
    zi = scipy.signal.sosfilt_zi(sos)[..., None] * x[0]
    return scipy.signal.sosfilt(sos, x, axis=0, zi=zi.reshape(zi.shape[:2] + x.shape[1:]))[0]


class LowpassStream:
    """Causal :func:`lowpass` one sample at a time for ``channels`` signals (direct form II transposed).

    The recursion is the compiled :func:`~spotfree.signal.recursions.lowpass_step`, the same one
    :class:`~spotfree.signal.features.FeatureStream` runs inside its own compiled step."""

    def __init__(self, sos: np.ndarray, channels: int):
        self.sos = np.asarray(sos, dtype=float)
        self.channels = channels
        self._sections, self._zi = sections_and_zi(self.sos)
        self._state = np.zeros((channels, len(self.sos), 2))
        self._x = np.zeros(channels)
        self._y = np.zeros(channels)
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next sample starts the filter at rest on its own value."""
        self._start = True

    def update(self, x) -> list[float]:
        """Filtered values for one sample ``x`` of ``channels`` values."""
        self._x[:] = x
        lowpass_step(self._sections, self._zi, self._state, self._start, self._x, self._y)
        self._start = False
        return self._y.tolist()


def sections_and_zi(sos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sos`` as the ``(s, 5)`` rows ``[b0, b1, b2, a1, a2]`` of :func:`~spotfree.signal.recursions.lowpass_step` and
    its at-rest state per unit input ``(s, 2)`` (``scipy.signal.sosfilt_zi``)."""
    sos = np.asarray(sos, dtype=float)
    return np.ascontiguousarray(sos[:, [0, 1, 2, 4, 5]]), np.ascontiguousarray(scipy.signal.sosfilt_zi(sos))
