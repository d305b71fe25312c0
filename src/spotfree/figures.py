"""Figures: the training diagnostic (each training recording coloured by the names its windows were given)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from spotfree.io.recording import Recording  # noqa: E402
from spotfree.learner import SetSupervisedLearner  # noqa: E402


def training_figure(learner: SetSupervisedLearner, recordings: list[Recording], path: str | Path) -> None:
    """One row per training recording: the model's first channel, each window's centre coloured by the class the
    fitted ``learner`` named it."""
    model = learner.model_
    channel = model.channels[0]
    colour = {c: plt.get_cmap("tab10")(i % 10) for i, c in enumerate(learner.classes_)}
    fig, axes = plt.subplots(len(recordings), 1, figsize=(12, 2.4 * len(recordings)), squeeze=False)
    for ax, rec, names, ends in zip(axes[:, 0], recordings, learner.window_labels_, learner.window_ends_):
        signal = rec.channels[channel]
        centre = ends - model.window // 2
        ax.plot(rec.time, signal, color="0.85", lw=0.8)
        ax.scatter(rec.time[centre], signal[centre], c=[colour[n] for n in names], s=4)
        ax.set_ylabel(f"{Path(rec.source).name}\n{channel}", fontsize=8)
    handles = [plt.Line2D([], [], marker="o", ls="", color=colour[c], label=c) for c in learner.classes_]
    axes[0, 0].legend(handles=handles, fontsize=7, loc="upper right")
    axes[0, 0].set_title("training windows by the name the learner gave them", fontsize=9)
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
