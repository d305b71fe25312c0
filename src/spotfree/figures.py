"""Figures: the training diagnostic (signals coloured by cluster, per nesting level)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from spotfree.training import TrainingExperiment, TrainingResult  # noqa: E402


def training_figure(result: TrainingResult, experiments: list[TrainingExperiment], path: str | Path) -> None:
    """One row per recording: its first channel coloured by level-1 cluster, by nested cluster, and by final name
    (grey where purification dropped the window)."""
    channel = result.model.channels[0]
    classes = result.model.classes
    n = len(experiments)
    fig, axes = plt.subplots(n, 3, figsize=(15, 2.6 * n), squeeze=False, sharex="row")
    cmap = plt.get_cmap("tab10")
    method = {"osc": "OSC", "kmeans": "k-means"}.get(result.model.parameters.get("clustering"), "level-1")
    titles = [f"level 1: {method} clusters", "level 2: nested split, background re-clustered",
              "dictionary: kept windows by name"]
    for r, exp in enumerate(experiments):
        rec = exp.recording
        signal = rec.channels[channel]
        ends = result.ends[r]
        centre = ends - result.model.window // 2
        t = rec.time[centre]
        for col, labels in enumerate([result.levels[0][r], result.levels[1][r]]):
            ax = axes[r, col]
            ax.plot(rec.time, signal, color="0.85", lw=0.8)
            ax.scatter(t, signal[centre], c=[cmap(int(k) % 10) for k in labels], s=4)
        ax = axes[r, 2]
        ax.plot(rec.time, signal, color="0.85", lw=0.8)
        kept = result.kept[r]
        model_class = {c: i for i, c in enumerate(classes)}
        names = result.window_names[r]
        colours = [cmap(model_class[nm] % 10) if k and nm in model_class else (0.6, 0.6, 0.6, 0.3)
                   for nm, k in zip(names, kept)]
        ax.scatter(t, signal[centre], c=colours, s=4)
        axes[r, 0].set_ylabel(f"{Path(rec.source).name}\n{channel}")
        for col in range(3):
            axes[r, col].set_title(titles[col] if r == 0 else "", fontsize=9)
    handles = [plt.Line2D([], [], marker="o", ls="", color=cmap(i % 10), label=c) for i, c in enumerate(classes)]
    axes[0, 2].legend(handles=handles, fontsize=7, loc="upper right")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

