"""The paper's PI complementary filter: the bilinear design, the printed difference equation, batch = streaming."""

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st

from spotfree.errors import InputError
from spotfree.signal.complementary import (
    PAPER_KI,
    PAPER_KP,
    PIComplementaryStream,
    pi_complementary,
    pi_complementary_design,
)

# The paper's printed difference equation (section III), without its extra z^-1 (see test_printed_delay).
PRINTED_GYRO = (0.907, -1.814, 0.819)
PRINTED_ACC = (0.093, 0.0048, -0.0882)
PRINTED_DEN = (1.0, -1.8091, 0.8188)


def _matches_to_printed_digits(value: float, printed: float) -> bool:
    """True when ``value`` rounds to ``printed`` at the number of decimals the paper printed."""
    decimals = len(repr(printed).split(".")[1])
    return abs(value - printed) <= 0.5 * 10.0**-decimals + 1e-12


@pytest.mark.parametrize("rate", [20.0, 38.0, 285.714])
def test_closed_form_equals_scipy_bilinear(rate):
    d = pi_complementary_design(rate=rate)
    den = [1.0, PAPER_KP, PAPER_KI]
    for num, b in [([1.0, 0.0, 0.0], d.b_gyro), ([1.0, 0.0], d.b_rate), ([PAPER_KP, PAPER_KI], d.b_acc)]:
        b_ref, a_ref = scipy.signal.bilinear(num, den, fs=rate)
        np.testing.assert_allclose(np.pad(b_ref, (3 - len(b_ref), 0)), b, atol=1e-14)
        np.testing.assert_allclose(a_ref, d.a, atol=1e-14)


@settings(max_examples=60, deadline=None)
@given(
    kp=st.floats(0.01, 100.0),
    ki=st.floats(0.001, 1000.0),
    rate=st.floats(1.0, 2000.0),
)
def test_any_design_is_complementary_stable_and_bilinear(kp, ki, rate):
    d = pi_complementary_design(kp, ki, rate)
    np.testing.assert_allclose(d.b_gyro + d.b_acc, d.a, rtol=0, atol=1e-12)
    assert np.all(np.abs(np.roots(d.a)) < 1.0)  # the bilinear map keeps the stable continuous poles inside
    b_ref, a_ref = scipy.signal.bilinear([kp, ki], [1.0, kp, ki], fs=rate)
    np.testing.assert_allclose(d.b_acc, b_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(d.a, a_ref, rtol=1e-9, atol=1e-12)


def test_paths_are_complementary_and_rate_path_is_trapezoid_then_angle_path():
    d = pi_complementary_design(rate=20.0)
    np.testing.assert_allclose(d.b_gyro + d.b_acc, d.a, atol=1e-15)
    # b_rate (1 - z^-1) = b_gyro * T/2 (1 + z^-1): trapezoidal integration, then the angle path
    np.testing.assert_allclose(np.convolve(d.b_rate, [1, -1]), np.convolve(d.b_gyro, [0.5 / 20.0, 0.5 / 20.0]), atol=1e-15)
    assert abs(np.sum(d.b_acc) / np.sum(d.a) - 1.0) < 1e-12  # accelerometer path: DC gain 1
    assert abs(np.sum(d.b_gyro)) < 1e-15  # gyro angle path blocks DC (and a constant rate bias)


def test_discrete_response_follows_eq3_well_below_nyquist():
    d = pi_complementary_design(rate=100.0)
    f = np.array([0.05, 0.2, 0.7, 2.0])  # Hz
    _, h_acc = scipy.signal.freqz(d.b_acc, d.a, worN=f, fs=100.0)
    _, h_ref = scipy.signal.freqs([PAPER_KP, PAPER_KI], [1.0, PAPER_KP, PAPER_KI], worN=2 * np.pi * f)
    np.testing.assert_allclose(h_acc, h_ref, atol=2e-3)


def test_printed_denominator_solves_to_38_hz_and_ki_15():
    _, a1, a2 = PRINTED_DEN
    # 1 - a2 = 2 Kp c / D0 and 1 - a1 + a2 = 4 c^2 / D0, so their ratio is Kp / (2 c) = Kp / (4 rate)
    rate = PAPER_KP * (1 - a1 + a2) / (4 * (1 - a2))
    ki = (2 * rate) ** 2 * (1 + a1 + a2) / (1 - a1 + a2)
    assert rate == pytest.approx(38.0, abs=0.05)
    assert ki == pytest.approx(15.45, abs=0.05)
    d = pi_complementary_design(PAPER_KP, ki, rate)
    # all printed coefficients match to their printed digits ...
    for value, printed in [*zip(d.a, PRINTED_DEN), *zip(d.b_acc, PRINTED_ACC), *zip(d.b_gyro[:2], PRINTED_GYRO[:2])]:
        assert _matches_to_printed_digits(value, printed), (value, printed)
    # ... except the last gyro coefficient: the design is symmetric (0.907), the print says 0.819
    assert _matches_to_printed_digits(d.b_gyro[2], 0.907)
    assert not _matches_to_printed_digits(d.b_gyro[2], PRINTED_GYRO[2])


def test_printed_last_gyro_coefficient_breaks_complementarity():
    # gyro + accelerometer numerators must sum to the denominator, within the printed rounding (0.0006)
    sums = np.add(PRINTED_GYRO, PRINTED_ACC)
    np.testing.assert_allclose(sums[:2], PRINTED_DEN[:2], atol=6e-4)
    assert abs(sums[2] - PRINTED_DEN[2]) > 0.08
    assert abs(0.907 + PRINTED_ACC[2] - PRINTED_DEN[2]) < 6e-4


def test_paper_gains_do_not_reproduce_the_print_at_any_single_rate():
    # with both printed gains, the rate that matches a1 and the one that matches a2 differ by ~0.7 Hz
    rates = np.linspace(30.0, 50.0, 20001)
    a = np.array([pi_complementary_design(rate=r).a for r in rates])
    rate_a1 = rates[np.argmin(np.abs(a[:, 1] - PRINTED_DEN[1]))]
    rate_a2 = rates[np.argmin(np.abs(a[:, 2] - PRINTED_DEN[2]))]
    assert rate_a1 == pytest.approx(38.65, abs=0.01) and rate_a2 == pytest.approx(37.97, abs=0.01)
    at_20 = pi_complementary_design(rate=20.0)
    assert not _matches_to_printed_digits(at_20.a[1], PRINTED_DEN[1])


def test_printed_delay_is_one_sample():
    d = pi_complementary_design(rate=20.0)
    x = np.random.default_rng(3).normal(size=200)
    delayed = scipy.signal.lfilter(np.r_[0.0, d.b_acc], d.a, x)
    np.testing.assert_allclose(delayed[1:], scipy.signal.lfilter(d.b_acc, d.a, x)[:-1], atol=1e-12)


def test_batch_and_streaming_agree():
    rng = np.random.default_rng(7)
    n = 3000
    angle = np.cumsum(rng.normal(0, 0.01, (n, 2)), axis=0) + rng.normal(0, 0.05, (n, 2))
    rate = rng.normal(0, 0.3, (n, 2))
    d = pi_complementary_design(rate=20.0)
    batch = pi_complementary(angle, rate, d)
    stream = PIComplementaryStream(d, channels=2)
    online = np.array([stream.update(a, w) for a, w in zip(angle.tolist(), rate.tolist())])
    np.testing.assert_allclose(online, batch, rtol=0, atol=1e-12)
    stream.reset()
    np.testing.assert_allclose(stream.update(angle[0], rate[0]), batch[0], atol=1e-12)


def test_starts_at_rest_and_rejects_gyro_bias():
    d = pi_complementary_design(rate=20.0)
    n = 2000
    angle = np.full((n, 1), 0.3)
    out = pi_complementary(angle, np.zeros((n, 1)), d)
    np.testing.assert_allclose(out, 0.3, atol=1e-12)
    biased = pi_complementary(angle, np.full((n, 1), 0.05), d)  # 2.9 deg/s bias
    assert abs(biased[-1, 0] - 0.3) < 1e-6


def test_gyro_carries_the_fast_part_and_accelerometer_the_slow_part():
    rate_hz, n = 20.0, 4000
    t = np.arange(n) / rate_hz
    truth = 0.2 * np.sin(2 * np.pi * 0.5 * t)
    rate = np.gradient(truth, 1 / rate_hz)
    noisy_acc = truth + 0.2 * np.sin(2 * np.pi * 4.0 * t)  # 4 Hz disturbance on the accelerometer angle
    out = pi_complementary(noisy_acc[:, None], rate[:, None], pi_complementary_design(rate=rate_hz))[:, 0]
    assert np.sqrt(np.mean((out - truth) ** 2)) < 0.3 * np.sqrt(np.mean((noisy_acc - truth) ** 2))


def test_bad_parameters_raise_input_error():
    with pytest.raises(InputError, match="rate"):
        pi_complementary_design(rate=0.0)
    with pytest.raises(InputError, match="Kp"):
        pi_complementary_design(kp=-1.0)
    with pytest.raises(InputError, match="shape"):
        pi_complementary(np.zeros((5, 2)), np.zeros((5, 1)), pi_complementary_design())
