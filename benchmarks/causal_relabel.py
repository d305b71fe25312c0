"""A lead for causal labelling, measured but not built into training: name each dictionary column by the window
centred on its last sample.

Training names every window by its cluster, and a window's name describes its centre. A causal classifier labels
the last sample of a window, so it answers half a window late at every change of state. This script keeps the
training of ``spotfree evaluate`` (seed by seed), then builds a second dictionary from the same training windows,
each window named by the (kept, named) window centred on its last sample; windows that straddle a change are
allowed in, which the trained dictionary drops. Both dictionaries label the evaluation's tests causally with
kernel CRC_RLS; also printed is the median delay from each true onset of sudden braking to its label
(:mod:`spotfree.classify.latency`). No ground truth is read for either; the tests' truth only scores them.

    python benchmarks/causal_relabel.py --seeds 0 2 3
"""

from __future__ import annotations

import argparse
import warnings
from dataclasses import replace

import numpy as np

from spotfree.classify.batch import classify_recording, dictionary_classifier
from spotfree.classify.latency import decision_latency
from spotfree.evaluation.protocol import SCENARIOS, Protocol, simulate, train_dictionary
from spotfree.windows import ChannelScaling, recording_windows


def causal_dictionary(trained, max_columns: int = 100):
    """The trained model with its columns replaced by the training windows named by the window centred on their
    last sample (at most ``max_columns`` per class, evenly over time)."""
    result, model = trained.result, trained.result.model
    shift = (model.window // 2) // model.parameters["train_step"]
    scaling = ChannelScaling(tuple(model.channels), model.scale)
    columns, names = [], []
    for r, experiment in enumerate(trained.experiments):
        windows = recording_windows(experiment.recording, tuple(model.channels), model.window,
                                    model.parameters["train_step"], scaling, model.normalisation)
        own, kept = result.window_names[r], result.kept[r]
        for k in range(len(own) - shift):
            if own[k] != "" and kept[k + shift] and own[k + shift] != "":
                columns.append(windows.matrix[:, k])
                names.append(own[k + shift])
    columns, names = np.array(columns).T, np.array(names)
    chosen = []
    for c in model.classes:
        index = np.flatnonzero(names == c)
        chosen.append(index[np.linspace(0, len(index) - 1, min(len(index), max_columns)).round().astype(int)]
                      if len(index) else index)
    chosen = np.sort(np.concatenate(chosen))
    classes = list(model.classes)
    return replace(model, dictionary=columns[:, chosen],
                   column_class=np.array([classes.index(c) for c in names[chosen]]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 2, 3])
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print("| seed | dictionary | columns per class | normal-braking | sudden-braking | cruising | all tests | "
          "sudden labels in normal tests | sudden-braking onsets: median causal delay (s) |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|")
    for seed in args.seeds:
        protocol = Protocol(seed=seed)
        data = simulate(protocol)
        trained = train_dictionary(data, protocol)
        for name, model in (("trained", trained.result.model), ("centre-named", causal_dictionary(trained))):
            clf = dictionary_classifier(model, "kcrc")
            right = total = 0
            cells, false_sudden = [], 0
            for scenario in SCENARIOS:
                test = data[scenario].test
                label = classify_recording(model, test, "kcrc", classifier=clf).label
                scored = label != ""
                hits = int(np.sum(label[scored] == test.truth["label"][scored]))
                cells.append(f"{100 * hits / scored.sum():.2f}")
                right, total = right + hits, total + int(scored.sum())
                if scenario == "normal-braking":
                    false_sudden = int(np.sum(label == "sudden-braking"))
            counts = "/".join(str(int((model.column_class == i).sum())) for i in range(len(model.classes)))
            delay = decision_latency(model, data["sudden-braking"].test, "kcrc")["causal"].get("sudden-braking")
            onset = "-" if delay is None or delay.median is None else f"{delay.median:+.2f}"
            print(f"| {seed} | {name} | {counts} | {' | '.join(cells)} | {100 * right / total:.2f} | {false_sudden} "
                  f"| {onset} |")


if __name__ == "__main__":
    main()
