"""The causal columns of a trained model against its centre-named columns, both labelling causally.

Training names every window by its cluster, and a window's name describes its centre. A causal classifier labels
the last sample of a window, so with those columns it answers half a window late at every change of state. The
model therefore also carries causal columns (``spotfree.training._causal_columns``): the training windows named by
the window centred on their last sample. This script keeps the training of ``spotfree evaluate`` (seed by seed) and
labels the evaluation's tests causally with kernel CRC_RLS on each column set, with the median delay from each true
onset of sudden braking to its label (:mod:`spotfree.classify.latency`). No ground truth is read for either; the
tests' truth only scores them.

    python benchmarks/causal_relabel.py --seeds 0 2 3
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from spotfree.classify.batch import classify_recording, dictionary_classifier
from spotfree.classify.latency import onset_latency
from spotfree.evaluation.protocol import SCENARIOS, Protocol, simulate, train_dictionary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 2, 3])
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print("| seed | columns | per class | normal-braking | sudden-braking | cruising | all tests | "
          "sudden labels in normal tests | sudden-braking onsets: median causal delay (s) |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|")
    for seed in args.seeds:
        protocol = Protocol(seed=seed)
        data = simulate(protocol)
        model = train_dictionary(data, protocol).result.model
        for name, causal in (("centre-named", False), ("causal", True)):
            clf = dictionary_classifier(model, "kcrc", causal=causal)
            right = total = false_sudden = 0
            cells, delay = [], "-"
            for scenario in SCENARIOS:
                test = data[scenario].test
                labels = classify_recording(model, test, "kcrc", classifier=clf)
                scored = labels.label != ""
                hits = int(np.sum(labels.label[scored] == test.truth["label"][scored]))
                cells.append(f"{100 * hits / scored.sum():.2f}")
                right, total = right + hits, total + int(scored.sum())
                if scenario == "normal-braking":
                    false_sudden = int(np.sum(labels.label == "sudden-braking"))
                if scenario == "sudden-braking":
                    onset = onset_latency(labels, test.truth["label"]).get("sudden-braking")
                    delay = "-" if onset is None or onset.median is None else f"{onset.median:+.2f}"
            counts = "/".join(str(int((model.columns(causal)[1] == i).sum())) for i in range(len(model.classes)))
            print(f"| {seed} | {name} | {counts} | {' | '.join(cells)} | {100 * right / total:.2f} | {false_sudden} "
                  f"| {delay} |")


if __name__ == "__main__":
    main()
