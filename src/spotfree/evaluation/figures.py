"""Figures: the results like the paper's (section V), the handlebar pitch angle of every test ride with the label
stream drawn on it and the ground truth as a band along the top of each panel; the training diagnostic, each
training recording coloured by the names its windows were given; confusion matrices; and event timelines, the true
events of a class beside the runs of labels that detect them along each test ride."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from spotfree.classify.batch import Labels  # noqa: E402
from spotfree.evaluation.metrics import EVENT_TOLERANCE, event_runs  # noqa: E402
from spotfree.io.checks import true_runs  # noqa: E402
from spotfree.io.recording import Recording  # noqa: E402

if TYPE_CHECKING:
    from spotfree.learner import SetSupervisedLearner

NONE_COLOUR = (0.6, 0.6, 0.6, 1.0)
"""Colour of samples with no label (the first window of a ride)."""


def class_colours(classes) -> dict[str, tuple]:
    """A fixed colour per class, in the order given (tab10)."""
    cmap = plt.get_cmap("tab10")
    return {str(c): cmap(i % 10) for i, c in enumerate(classes)}


def results_figure(test: Recording, labels: Labels, classes, path: str | Path, title: str) -> None:
    """One panel per experiment of ``test``: ``pitch`` (degrees; positive nose down) over time, each sample
    coloured by its label; the true class as a band along the top."""
    colours = class_colours(classes)
    experiments = [k for k, _ in test.experiments()]
    fig, axes = plt.subplots(len(experiments), 1, figsize=(11, 1.55 * len(experiments) + 0.9), squeeze=False)
    for ax, k in zip(axes[:, 0], experiments):
        rows = test.experiment == k if test.experiment is not None else np.ones(len(test), dtype=bool)
        t = test.time[rows]
        pitch = np.rad2deg(test.channels["pitch"][rows])
        label = labels.label[rows].astype(str)
        ax.plot(t, pitch, color="0.8", lw=0.7, zorder=1)
        ax.scatter(t, pitch, c=[colours.get(x, NONE_COLOUR) for x in label], s=2.5, lw=0, zorder=2)
        truth = test.truth["label"][rows].astype(str)
        for start, stop in _runs(truth):
            ax.axvspan(t[start], t[stop - 1] + 1.0 / test.rate, ymin=0.9, ymax=1.0, lw=0,
                       color=colours.get(truth[start], NONE_COLOUR))
        ax.set_ylabel(f"exp. {k}\npitch (deg)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_xlim(t[0], t[-1])
        low, high = np.nanmin(pitch), np.nanmax(pitch)
        ax.set_ylim(low - 0.05 * (high - low), high + 0.2 * (high - low))
    axes[-1, 0].set_xlabel("time (s)", fontsize=8)
    handles = [plt.Line2D([], [], marker="o", ls="", color=c, label=name) for name, c in colours.items()]
    fig.legend(handles=handles, loc="upper right", ncol=len(handles), fontsize=8, frameon=False)
    fig.suptitle(f"{title}: dots = labels, top band = ground truth", x=0.01, ha="left", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=90)
    plt.close(fig)


FIGURE_ROWS = 12
"""Most rows (training logs) of :func:`training_figure`."""


def training_figure(learner: SetSupervisedLearner, recordings: list[Recording], path: str | Path,
                    logs: list[str] | None = None) -> str:
    """One row per training log, at most :data:`FIGURE_ROWS` (the first logs): the model's first channel, each
    window's centre coloured by the class the fitted ``learner`` named it. ``logs`` names the log of each recording
    (spans of one log share its row, on its time axis); None: each recording is its own log. Returns what the figure
    shows, e.g. ``"12 of 115 training logs"``."""
    model = learner.model_
    channel = model.channels[0]
    colour = class_colours(learner.classes_)
    logs = logs if logs is not None else [rec.source for rec in recordings]
    distinct = list(dict.fromkeys(logs))
    shown = distinct[:FIGURE_ROWS]
    fig, axes = plt.subplots(len(shown), 1, figsize=(12, 2.4 * len(shown)), squeeze=False)
    row = dict(zip(shown, axes[:, 0]))
    for log, rec, names, ends in zip(logs, recordings, learner.window_labels_, learner.window_ends_):
        if log not in row:
            continue
        signal = rec.channels[channel]
        centre = ends - model.window // 2
        row[log].plot(rec.time, signal, color="0.85", lw=0.8)
        row[log].scatter(rec.time[centre], signal[centre], c=[colour[str(n)] for n in names], s=4)
    for log, ax in row.items():
        ax.set_ylabel(f"{Path(log).name}\n{channel}", fontsize=8)
    said = f"{len(shown)} of {len(distinct)} training logs" if len(shown) < len(distinct) else \
        f"{len(shown)} training log{'s' * (len(shown) > 1)}"
    handles = [plt.Line2D([], [], marker="o", ls="", color=c, label=name) for name, c in colour.items()]
    axes[0, 0].legend(handles=handles, fontsize=7, loc="upper right")
    axes[0, 0].set_title(f"training windows by the name the learner gave them ({said})", fontsize=9)
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return said


def confusion_figure(panels: list[tuple[str, np.ndarray, list[str], list[str]]], path: str | Path) -> None:
    """One heat map per ``(title, counts, rows, columns)`` of ``panels``: ``counts[i, j]`` samples of true class
    ``rows[i]`` labelled ``columns[j]``, each cell shaded by its share of the row (the row's recall on the diagonal)
    and written as that share in per cent above its count."""
    fig, axes = plt.subplots(1, len(panels), figsize=(4.3 * len(panels), 4.2), squeeze=False)
    for ax, (title, counts, rows, columns) in zip(axes[0], panels):
        counts = np.asarray(counts)
        share = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
        ax.imshow(share, cmap="Blues", vmin=0, vmax=1, aspect="auto")
        for (i, j), n in np.ndenumerate(counts):
            ax.text(j, i, f"{100 * share[i, j]:.1f}%\n{n}", ha="center", va="center", fontsize=7,
                    color="white" if share[i, j] > 0.6 else "black")
        ax.set_xticks(range(len(columns)), columns, rotation=35, ha="right", fontsize=7)
        ax.set_yticks(range(len(rows)), rows, fontsize=7)
        ax.set_xlabel("label", fontsize=8)
        ax.set_ylabel("true class", fontsize=8)
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def event_timeline(rides: list[tuple[str, np.ndarray, np.ndarray, dict[str, np.ndarray]]], title: str,
                   path: str | Path, tolerance: float = EVENT_TOLERANCE) -> None:
    """One row per ``(name, time, truth, detections)`` of ``rides``: the true events (runs of ``truth``, a boolean
    per sample) as black bars over time (s), and under them one lane per stream of ``detections`` (stream name ->
    boolean per sample), each run of it green when it meets a true event within ``tolerance`` s, red when it is a
    false alarm (:func:`~spotfree.evaluation.metrics.event_runs`)."""
    streams = list(rides[0][3]) if rides else []
    fig, axes = plt.subplots(len(rides), 1, figsize=(11, 0.3 * (len(streams) + 1) * len(rides) + 1.0),
                             squeeze=False)
    for ax, (name, t, truth, detections) in zip(axes[:, 0], rides):
        step = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
        lanes = len(detections)
        for lane, (stream, fired) in enumerate(detections.items()):
            _, runs, _, hits = event_runs(fired, truth, int(round(tolerance / step)))
            ax.broken_barh([(t[a], t[b - 1] - t[a] + step) for a, b in runs], (lanes - 1 - lane + 0.1, 0.8),
                           color=["tab:green" if hit else "tab:red" for hit in hits])
        ax.broken_barh([(t[a], t[b - 1] - t[a] + step) for a, b in true_runs(truth)], (lanes + 0.1, 0.8),
                       color="black")
        ax.set_yticks([lanes + 0.5, *[lanes - 0.5 - k for k in range(lanes)]], ["truth", *detections], fontsize=7)
        ax.set_ylim(0, lanes + 1)
        ax.set_xlim(t[0], t[-1] + step)
        ax.set_ylabel(name, fontsize=7, rotation=0, ha="right", va="center")
        ax.tick_params(axis="x", labelsize=7)
    axes[-1, 0].set_xlabel("time (s)", fontsize=8)
    fig.suptitle(f"{title}: black = true events; green = detection, red = false alarm", x=0.01, ha="left",
                 fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _runs(values: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of the runs of equal values."""
    edges = np.r_[0, np.flatnonzero(values[1:] != values[:-1]) + 1, len(values)]
    return list(zip(edges[:-1].tolist(), edges[1:].tolist()))
