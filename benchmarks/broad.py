"""BROAD trials: loading, block averaging and the inclination score.

BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7):72, 2021; CC BY 4.0) holds real IMU recordings with optical
ground truth; four of its trials sit in ``../shared/data/broad`` (README there). Every vector here is in the
IMU's own frame (the "body" frame): ``acc`` specific force in m/s^2 (gravity included, +9.81 up at rest),
``gyr`` angular rate in rad/s, ``up`` the true unit vertical (East-North-Up z axis) in body coordinates.

Score: the inclination error is the angle between the true and the estimated vertical in the body frame; a
trial's score is its RMSE in degrees over the samples of the movement phase that have a valid reference.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.io

TRIALS = (
    "02_undisturbed_slow_rotation_B",
    "09_undisturbed_fast_rotation_with_breaks_B",
    "16_undisturbed_fast_translation_B",
    "25_disturbed_tapping_B",
)
BLOCK = 14
"""Block length for the ~20 Hz runs: 285.714 Hz / 14 = 20.41 Hz."""


def data_dir() -> Path:
    """The folder of the .mat files: ``$SPOTFREE_BROAD`` or ``shared/data/broad`` beside the repository."""
    env = os.environ.get("SPOTFREE_BROAD")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared" / "data" / "broad"


@dataclass(frozen=True)
class Trial:
    """One trial on a uniform grid: ``acc`` (n, 3) m/s^2, ``gyr`` (n, 3) rad/s, ``up`` (n, 3) unit, body frame.

    ``scored`` marks the samples that count (movement phase, reference valid); ``rate`` is in Hz.
    """

    name: str
    acc: np.ndarray
    gyr: np.ndarray
    up: np.ndarray
    scored: np.ndarray
    rate: float


def up_from_quaternion(quat: np.ndarray) -> np.ndarray:
    """Unit vertical in the body frame, ``(n, 3)``, from body-to-ENU quaternions ``(n, 4)`` [w, x, y, z].

    It is the third row of the rotation matrix: ``[2(xz - wy), 2(yz + wx), 1 - 2(x^2 + y^2)]``.
    """
    w, x, y, z = np.asarray(quat, dtype=float).T
    return np.column_stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


def load_trial(name: str, folder: Path | None = None) -> Trial:
    """Read ``<folder>/<name>.mat`` (MATLAB v5) into a :class:`Trial` at the native rate."""
    raw = scipy.io.loadmat((folder or data_dir()) / f"{name}.mat", squeeze_me=True)
    quat = np.asarray(raw["opt_quat"], dtype=float)
    valid = np.all(np.isfinite(quat), axis=1)
    return Trial(
        name=name,
        acc=np.asarray(raw["imu_acc"], dtype=float),
        gyr=np.asarray(raw["imu_gyr"], dtype=float),
        up=up_from_quaternion(quat),
        scored=valid & (np.asarray(raw["movement"]) == 1),
        rate=float(raw["sampling_rate"]),
    )


def block_average(trial: Trial, block: int = BLOCK) -> Trial:
    """The trial at ``rate / block``: IMU samples averaged over non-overlapping blocks of ``block`` samples.

    A filter update with block ``k``'s mean rate integrates the orientation to the end of that block, so the
    reference (and whether the sample is scored) is taken from the block's last sample. A trailing partial
    block is dropped.
    """
    n = len(trial.acc) // block * block
    last = np.arange(block - 1, n, block)

    def mean(v: np.ndarray) -> np.ndarray:
        return v[:n].reshape(-1, block, 3).mean(axis=1)

    return Trial(trial.name, mean(trial.acc), mean(trial.gyr), trial.up[last], trial.scored[last], trial.rate / block)


def inclination_rmse(up_estimate: np.ndarray, trial: Trial) -> float:
    """RMSE (degrees) of the angle between estimated and true vertical over ``trial.scored`` samples.

    ``up_estimate`` is ``(n, 3)`` in the body frame; it need not be normalised.
    """
    est = np.asarray(up_estimate, dtype=float)[trial.scored]
    ref = trial.up[trial.scored]
    cos = np.sum(est * ref, axis=1) / (np.linalg.norm(est, axis=1) * np.linalg.norm(ref, axis=1))
    angle = np.arccos(np.clip(cos, -1.0, 1.0))
    return float(np.degrees(np.sqrt(np.mean(angle**2))))
