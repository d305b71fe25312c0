"""Signal processing of section III: attitude filters, frames, the acceleration low-pass, ride features.

* :mod:`~spotfree.signal.frame` -- device and vehicle axes, eq. (1), the body-to-level rotation;
* :mod:`~spotfree.signal.complementary` -- the paper's PI complementary filter (eq. 3, bilinear transform);
* :mod:`~spotfree.signal.orientation` -- the roll/pitch backends ``default`` (GravityPI), ``paper``, ``vqf``;
* :mod:`~spotfree.signal.butterworth` -- third-order Butterworth low-pass, causal and zero-phase;
* :mod:`~spotfree.signal.features` -- :func:`ride_features` and :class:`FeatureStream`;
* :mod:`~spotfree.signal.recursions` -- the compiled per-sample recursions behind the streaming forms.
"""

from spotfree.signal.butterworth import LowpassStream, butter_lowpass, lowpass
from spotfree.signal.complementary import PIComplementaryStream, pi_complementary, pi_complementary_design
from spotfree.signal.features import FEATURE_CHANNELS, FeatureStream, ride_features
from spotfree.signal.orientation import ORIENTATIONS, GravityPI, attitude_filter, estimate_attitude

__all__ = [
    "FEATURE_CHANNELS", "FeatureStream", "GravityPI", "LowpassStream", "ORIENTATIONS", "PIComplementaryStream",
    "attitude_filter", "butter_lowpass", "estimate_attitude", "lowpass", "pi_complementary",
    "pi_complementary_design", "ride_features",
]
