"""Third-order Butterworth low-pass on accelerations: design, causal batch = streaming, zero-phase offline."""

import numpy as np
import pytest
import scipy.signal

from spotfree.errors import InputError
from spotfree.signal.butterworth import ACC_CUTOFF, LowpassStream, butter_lowpass, lowpass


def test_design_is_third_order_butterworth_at_the_cutoff():
    sos = butter_lowpass(20.0)
    z, p, _ = scipy.signal.sos2zpk(sos)
    assert np.count_nonzero(np.abs(p) > 1e-12) == 3  # three poles (the second section is first order, padded)
    np.testing.assert_allclose(z[np.abs(z) > 1e-12], -1.0, atol=1e-5)  # zeros at Nyquist
    f = np.array([0.0, 2.0, ACC_CUTOFF, 6.0])
    _, h = scipy.signal.sosfreqz(sos, worN=f, fs=20.0)
    # the digital design is prewarped at the cut-off: |H| = 1/sqrt(2) there exactly
    np.testing.assert_allclose(np.abs(h[[0, 2]]), [1.0, 1 / np.sqrt(2)], atol=1e-9)
    assert np.abs(h[1]) > 0.95  # braking content passes
    assert np.abs(h[3]) < 0.13  # vibration an octave above is cut by more than 18 dB


def test_streaming_equals_causal_batch():
    rng = np.random.default_rng(11)
    x = rng.normal(size=(1500, 3)) + np.array([0.5, -1.0, 2.0])
    sos = butter_lowpass(20.0)
    batch = lowpass(x, sos)
    stream = LowpassStream(sos, channels=3)
    online = np.array([stream.update(row) for row in x.tolist()])
    np.testing.assert_allclose(online, batch, rtol=0, atol=1e-12)
    stream.reset()
    np.testing.assert_allclose(stream.update(x[0]), batch[0], atol=1e-12)


def test_constant_input_has_no_startup_transient():
    x = np.tile([1.5, -0.2, 9.0], (50, 1))
    sos = butter_lowpass(20.0)
    np.testing.assert_allclose(lowpass(x, sos), x, atol=1e-12)
    np.testing.assert_allclose(lowpass(x, sos, zero_phase=True), x, atol=1e-12)


def test_zero_phase_has_no_lag_and_causal_lags_about_two_samples():
    rate = 20.0
    t = np.arange(2000) / rate
    x = np.sin(2 * np.pi * 0.3 * t)[:, None]
    sos = butter_lowpass(rate)
    lags = np.arange(-5, 6)

    def best_lag(y):
        return lags[np.argmax([np.dot(x[100:-100, 0], np.roll(y[:, 0], -k)[100:-100]) for k in lags])]

    assert best_lag(lowpass(x, sos, zero_phase=True)) == 0
    assert best_lag(lowpass(x, sos)) == 2  # DC group delay 2 / (2 pi 3 Hz) = 0.106 s


@pytest.mark.parametrize("n", [0, 1, 2, 7])
def test_short_segments(n):
    x = np.ones((n, 3))
    sos = butter_lowpass(20.0)
    for zero_phase in (False, True):
        y = lowpass(x, sos, zero_phase=zero_phase)
        assert y.shape == (n, 3)
        np.testing.assert_allclose(y, 1.0, atol=1e-12)


def test_rate_too_low_for_the_cutoff():
    with pytest.raises(InputError, match="resample"):
        butter_lowpass(5.0)
