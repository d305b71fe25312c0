"""Which decision rule makes the most of a spotting-free dictionary: CRC residuals against nearest neighbours.

A development seed (not the evaluation's): the dictionary is trained without labels on experiment 1 of the
normal-braking and sudden-braking files (``TrainingConfig`` defaults, or the ``--affine`` / ``--max-columns``
given), and experiments 2-7 of both files are classified with causal windows. Rules on the same dictionary:
CRC_RLS at several ridge weights, and the 1- and 5-nearest-neighbour vote among the dictionary's columns
(Euclidean, the windows as the dictionary stores them). Printed: per-sample accuracy of the normal-braking and the
sudden-braking tests and the paper's count (sudden-braking labels inside the normal-braking tests).

    python benchmarks/dictionary_rules.py --seed 100
"""

from __future__ import annotations

import argparse

import numpy as np
from sklearn.neighbors import KNeighborsClassifier

from spotfree.classify.batch import classify_recording, dictionary_classifier
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario
from spotfree.training import TrainingConfig, TrainingExperiment, dictionary_purity, train
from spotfree.windows import ChannelScaling, recording_windows


def score(predict, tests) -> str:
    """``predict(rec) -> (labels, truth)``; accuracy of each test group and the false sudden-braking count."""
    cells = []
    for name, group in tests.items():
        pairs = [predict(t) for t in group]
        labels = np.concatenate([p for p, _ in pairs])
        truth = np.concatenate([t for _, t in pairs])
        cell = f"{name} {np.mean(labels == truth):.3f}"
        if name == "normal-braking":
            cell += f" (sudden labels {int(np.sum(labels == 'sudden-braking'))} of {len(labels)})"
        cells.append(cell)
    return "; ".join(cells)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=100)
    parser.add_argument("--affine", type=float, default=None)
    parser.add_argument("--max-columns", type=int, default=None)
    args = parser.parse_args()
    files = {s: ride_features(simulate_scenario(s, repeats=7, seed=args.seed), derived=True)
             for s in ("normal-braking", "sudden-braking")}
    experiments = [TrainingExperiment(rec.select_experiment(1), list(CLASSES[s])) for s, rec in files.items()]
    overrides = {k: v for k, v in (("affine", args.affine), ("max_columns", args.max_columns)) if v is not None}
    result = train(experiments, TrainingConfig(**overrides))
    model = result.model
    print(f"seed {args.seed}, {overrides or 'defaults'}: columns {model.summary['columns_per_class']}, "
          f"purity { {c: round(p, 3) for c, p in dictionary_purity(result, experiments).items()} }")
    tests = {s: [rec.select_experiment(k) for k in range(2, 8)] for s, rec in files.items()}

    def crc(alpha):
        clf = dictionary_classifier(model, "crc", alpha=alpha)

        def predict(rec):
            labels = classify_recording(model, rec, classifier=clf).label
            named = labels != ""
            return labels[named], rec.truth["label"][named]
        return predict

    scaling = ChannelScaling(tuple(model.channels), model.scale)
    atoms_class = np.asarray(model.classes)[model.column_class]

    def neighbours(k):
        knn = KNeighborsClassifier(k).fit(model.dictionary.T, atoms_class)

        def predict(rec):
            w = recording_windows(rec, tuple(model.channels), model.window, 1, scaling, model.normalisation)
            return knn.predict(w.matrix.T), rec.truth["label"][w.ends]
        return predict

    for alpha in (1e-3, 1e-1, 10.0):
        print(f"CRC_RLS alpha {alpha:g}: {score(crc(alpha), tests)}", flush=True)
    for k in (1, 5):
        print(f"{k}-NN among the columns: {score(neighbours(k), tests)}", flush=True)


if __name__ == "__main__":
    main()
