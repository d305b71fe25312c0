"""The paper's PI complementary filter (section III, eq. 2 and 3), discretised by the bilinear transform.

Continuous form, per angle (roll or pitch, rad), with ``phi_g = (1/s) omega`` the gyro angle (``omega`` the gyro
rate, rad/s) and ``phi_a`` the accelerometer angle of eq. (1)::

    phi_f = s^2 / (s^2 + Kp s + Ki) * phi_g  +  (Kp s + Ki) / (s^2 + Kp s + Ki) * phi_a          (eq. 3)

The two transfer functions sum to one (complementary), the gyro path is high-pass (a double zero at s = 0 rejects
a constant gyro bias once integrated), the accelerometer path low-pass. The paper's gains are Kp = 7.5924 1/s
and Ki = 20.7015 1/s^2 (natural frequency sqrt(Ki) = 4.55 rad/s = 0.72 Hz, damping Kp / (2 sqrt(Ki)) = 0.83).

Bilinear transform ``s = c (1 - z^-1) / (1 + z^-1)``, ``c = 2 / T = 2 * rate``, ``D0 = c^2 + Kp c + Ki``::

    a      = [1, 2 (Ki - c^2) / D0, (c^2 - Kp c + Ki) / D0]       common denominator
    b_gyro = c^2 / D0 * [1, -2, 1]                                 on the gyro angle phi_g
    b_rate = c / D0 * [1, 0, -1]                                   on the gyro rate omega (= b_gyro * T/2 (1+z^-1)/(1-z^-1))
    b_acc  = [Kp c + Ki, 2 Ki, Ki - Kp c] / D0                     on phi_a

``b_gyro + b_acc = a`` exactly. The filter is applied to the rate (``b_rate``), which equals trapezoidal
integration followed by ``b_gyro`` but keeps no unbounded integrator state.

The paper prints the difference equation with numerators ``0.907 z^-1 - 1.814 z^-2 + 0.819 z^-3`` (gyro angle),
``0.093 z^-1 + 0.0048 z^-2 - 0.0882 z^-3`` (accelerometer) over ``1 - 1.8091 z^-1 + 0.8188 z^-2``, which is not the
20 Hz design (there ``a = [1, -1.6413, 0.6844]``). Solving the printed denominator for the design
(``(1 - a2) / (1 - a1 + a2) = Kp / (2c)`` and ``(1 + a1 + a2) / (1 - a1 + a2) = Ki / c^2``) gives, with
Kp = 7.5924, a rate of 38.00 Hz and Ki = 15.45, not 20.7015 (with Ki = 20.7015 the same pair needs 44.0 Hz and
Kp = 8.79): the printed equation fixes only ``Kp T`` and ``Ki T^2``, and no single rate reproduces it with both
printed gains. The bilinear design at 38.00 Hz with Kp = 7.5924, Ki = 15.45 matches every printed coefficient to
its printed digits except the last gyro one: the design gives 0.907 (``b_gyro`` is symmetric), the paper 0.819,
which breaks complementarity (0.819 - 0.0882 != 0.8188) and gives the gyro path a DC gain of -9; it is a misprint.
The extra ``z^-1`` on every printed numerator is a one-sample delay (output at k from inputs up to k - 1, as a
Simulink model with a unit delay in the loop computes it): same magnitude response, one sample more lag. It is
not part of eq. (3) and is not applied here. Full derivation: ``docs/complementary_filter.md``.

Coefficients are designed apart from being applied (as ``scipy.signal``): :func:`pi_complementary_design`
returns them, :func:`pi_complementary` filters whole arrays with ``scipy.signal.lfilter``, and
:class:`PIComplementaryStream` filters one sample at a time with explicit state; both agree to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from spotfree.errors import InputError
from spotfree.signal.recursions import pi_complementary_channels

PAPER_KP = 7.5924
"""Proportional gain of the paper (1/s)."""
PAPER_KI = 20.7015
"""Integral gain of the paper (1/s^2)."""


@dataclass(frozen=True)
class PIDesign:
    """Discrete coefficients of eq. (3) at ``rate`` Hz (see the module docstring for the formulas).

    ``a`` is the common denominator; ``b_gyro`` acts on the gyro angle, ``b_rate`` on the gyro rate (rad/s)
    and ``b_acc`` on the accelerometer angle (rad). All are length-3 arrays in powers of ``z^-1``.
    """

    kp: float
    ki: float
    rate: float
    a: np.ndarray
    b_gyro: np.ndarray
    b_rate: np.ndarray
    b_acc: np.ndarray


def pi_complementary_design(kp: float = PAPER_KP, ki: float = PAPER_KI, rate: float = 20.0) -> PIDesign:
    """Bilinear-transform coefficients of eq. (3) with gains ``kp`` (1/s), ``ki`` (1/s^2) at ``rate`` (Hz)."""
    if not (np.isfinite(rate) and rate > 0):
        raise InputError(f"complementary filter: rate must be a positive number of Hz, got {rate}")
    if not (kp > 0 and ki > 0):
        raise InputError(f"complementary filter: gains Kp and Ki must be positive, got Kp={kp}, Ki={ki}")
    c = 2.0 * rate
    d0 = c * c + kp * c + ki
    return PIDesign(
        kp=kp,
        ki=ki,
        rate=rate,
        a=np.array([1.0, 2.0 * (ki - c * c) / d0, (c * c - kp * c + ki) / d0]),
        b_gyro=c * c / d0 * np.array([1.0, -2.0, 1.0]),
        b_rate=c / d0 * np.array([1.0, 0.0, -1.0]),
        b_acc=np.array([kp * c + ki, 2.0 * ki, ki - kp * c]) / d0,
    )


def _initial_state(design: PIDesign, angle0: np.ndarray) -> np.ndarray:
    """Direct-form-II-transposed state ``(2, m)`` for a filter at rest on ``angle0`` (gyro at zero rate)."""
    return np.outer(scipy.signal.lfilter_zi(design.b_acc, design.a), angle0)


def pi_complementary(angle_acc: np.ndarray, rate: np.ndarray, design: PIDesign) -> np.ndarray:
    """Filtered angles ``(n, m)`` (rad) from accelerometer angles and gyro rates, both ``(n, m)``.

    Column ``j`` of ``angle_acc`` (rad) pairs with column ``j`` of ``rate`` (rad/s about the same axis). The
    filter starts at rest on the first accelerometer angle, so there is no start-up transient.
    """
    angle_acc = np.atleast_2d(np.asarray(angle_acc, dtype=float).T).T
    rate = np.atleast_2d(np.asarray(rate, dtype=float).T).T
    if angle_acc.shape != rate.shape:
        raise InputError(f"complementary filter: angles {angle_acc.shape} and rates {rate.shape} differ in shape")
    if len(angle_acc) == 0:
        return angle_acc.copy()
    zi = _initial_state(design, angle_acc[0])
    from_acc, _ = scipy.signal.lfilter(design.b_acc, design.a, angle_acc, axis=0, zi=zi)
    return from_acc + scipy.signal.lfilter(design.b_rate, design.a, rate, axis=0)


class PIComplementaryStream:
    """Streaming form of :func:`pi_complementary` for ``channels`` angles, one sample per :meth:`update`.

    The state is the direct-form-II-transposed pair ``(z1, z2)`` per channel, shared by both inputs (they have
    the same denominator): ``y = bg0 w + ba0 x + z1``, ``z1 <- bg1 w + ba1 x - a1 y + z2``,
    ``z2 <- bg2 w + ba2 x - a2 y`` with ``w`` the rate and ``x`` the accelerometer angle (compiled:
    :func:`~spotfree.signal.recursions.pi_complementary_sample`).
    """

    def __init__(self, design: PIDesign, channels: int = 2):
        self.design = design
        self.channels = channels
        self._coefficients, self._zi = stream_coefficients(design)
        self._state = np.zeros((channels, 2))
        self._out = np.zeros(channels)
        self.reset()

    def reset(self) -> None:
        """Forget the past: the next sample starts the filter at rest on its accelerometer angle."""
        self._start = True

    def update(self, angle_acc, rate) -> list[float]:
        """Filtered angles (rad) for one sample: ``angle_acc`` (rad) and ``rate`` (rad/s), ``channels`` each."""
        angle_acc, rate = np.asarray(angle_acc, dtype=float), np.asarray(rate, dtype=float)
        if angle_acc.shape != self._out.shape or rate.shape != self._out.shape:
            raise InputError(f"complementary filter: one sample takes {self.channels} angles and {self.channels} "
                             f"rates, got shapes {angle_acc.shape} and {rate.shape}")
        pi_complementary_channels(self._coefficients, self._zi, self._state, self._start, angle_acc, rate, self._out)
        self._start = False
        return self._out.tolist()


def stream_coefficients(design: PIDesign) -> tuple[np.ndarray, np.ndarray]:
    """``design`` as :func:`~spotfree.signal.recursions.pi_complementary_sample` takes it: ``[a1, a2, br0, br1, br2,
    ba0, ba1, ba2]`` and the at-rest state per unit accelerometer angle ``(2,)`` (``scipy.signal.lfilter_zi``)."""
    coefficients = np.concatenate([design.a[1:], design.b_rate, design.b_acc]).astype(float)
    return coefficients, np.asarray(scipy.signal.lfilter_zi(design.b_acc, design.a), dtype=float)
