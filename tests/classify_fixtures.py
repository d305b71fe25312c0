"""Shared by the classification tests: simulated rides and dictionaries cut from them with the hidden truth.

Test modules import the fixtures ``raw`` and ``model`` from here.

A dictionary whose columns are named by the simulator's ``label`` column tests the classification mechanics
(windows, alignment, gaps, streaming); it is not a trained model (training never reads ``label``).
"""

import numpy as np
import pytest

from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.representation import represent
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario
from spotfree.windows import ChannelScaling, recording_windows

CHANNELS = ("lean", "acc_x")


def rides(seed: int = 1, repeats: int = 2) -> Recording:
    """``repeats`` simulated sudden-braking rides (raw IMU, 20 Hz, truth labels) in one Recording."""
    return simulate_scenario("sudden-braking", repeats=repeats, seed=seed)


@pytest.fixture(scope="module")
def raw() -> Recording:
    """Two sudden-braking rides, seed 1."""
    return rides()


@pytest.fixture(scope="module")
def model(raw) -> DictionaryModel:
    """A truth-named dictionary from the first ride of :func:`raw`."""
    return truth_model(raw.select_experiment(1))


def truth_model(raw: Recording, channels=CHANNELS, window: int = 20, step: int = 1, normalisation: str = "scale",
                affine: float = 6.0, features: str = "ride", stride: int = 3,
                representation: str = "hankel") -> DictionaryModel:
    """A dictionary of every ``stride``-th window of ``raw``'s ride features, each named by the true label at its
    centre; a ``summary`` one standardised over its columns (and without the affine row)."""
    feats = ride_features(raw, derived=True)
    scaling = ChannelScaling(tuple(channels)).fit([feats])
    windows = recording_windows(feats, tuple(channels), window, stride, scaling, normalisation)
    names = feats.truth["label"][windows.ends - window // 2]
    classes = sorted(set(names))
    columns, offset, scale, parameters = windows.matrix, None, None, {"affine": affine}
    if representation == "summary":
        rows = represent(windows.matrix, len(channels), "summary")
        offset, scale, parameters = rows.mean(axis=0), rows.std(axis=0), {}
        scale = np.where(scale > 1e-6 * scale.max(), scale, 1.0)
        columns = ((rows - offset) / scale).T
    return DictionaryModel(
        classes=classes, channels=list(channels), rate=feats.rate, window=window, step=step,
        normalisation=normalisation, scale=scaling.scale, dictionary=columns,
        column_class=np.array([classes.index(n) for n in names]), features=features,
        parameters=parameters, representation=representation, feature_offset=offset, feature_scale=scale,
    )


def with_gap(rec: Recording, start: int, stop: int) -> Recording:
    """A copy of ``rec`` whose samples ``start:stop`` are NaN in every channel (a reported gap)."""
    channels = {name: values.copy() for name, values in rec.channels.items()}
    for values in channels.values():
        values[start:stop] = np.nan
    return rec.with_channels(channels)


def amplitude_data(seed: int, d: int = 40, atoms: int = 60, windows: int = 50):
    """Two classes of windows of one shape, a soft one (amplitude about 1) and a hard one (about 3), with noise;
    and windows of another shape, far from both."""
    rng = np.random.default_rng(seed)
    shape = np.sin(np.linspace(0, np.pi, d))

    def draw(amplitude, n):
        return np.outer(amplitude * rng.uniform(0.8, 1.2, n), shape) + 0.05 * rng.normal(size=(n, d))

    X = np.vstack([draw(1.0, atoms), draw(3.0, atoms)])
    y = np.repeat(["soft", "hard"], atoms)
    test = np.vstack([draw(1.0, windows), draw(3.0, windows)])
    outside = 2.0 * np.cos(np.linspace(0, 3 * np.pi, d)) + 0.05 * rng.normal(size=(windows, d))
    return X, y, test, np.repeat(["soft", "hard"], windows), outside
