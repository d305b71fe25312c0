"""``report.md``: what one evaluation run measured, in tables with the paper's figures beside ours.

Every number comes from the run (:class:`Evaluation`) except the paper's own, quoted in :data:`PAPER` with the
section they are taken from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spotfree.classify.latency import onset_latency
from spotfree.evaluation.measure import ALIGNMENTS, HEADLINE, METHODS, MethodRuns
from spotfree.evaluation.metrics import (
    EVENT_TOLERANCE,
    TRANSITION_BAND,
    EventScore,
    Score,
    accuracy,
    class_accuracy,
    confusion_matrix,
    event_detection,
    label_count,
    near_transitions,
)
from spotfree.evaluation.lateral_road import MODELS
from spotfree.evaluation.protocol import SCENARIOS, TRAIN_EXPERIMENT, TRAINED_ON, Protocol, ScenarioData, Trained
from spotfree.evaluation.ride_models import STREAM_GOAL_US, RideModels
from spotfree.sim.scenarios import CLASSES

PAPER = {
    "normal_sudden_labels": Score(6, 7800),
    "experiment_samples": 1300,
    "seconds_per_1000": {"crc": 0.39, "bsrc": 112.0},
}
"""The paper's numbers: section V (six sudden-braking labels in 7800 labels of the six normal-braking tests, a mean
experiment length of 1300 samples at 20 Hz) and section IV-A (1000 time samples classified in 0.39 s by CRC_RLS
and 112 s by B_SRC); the paper gives no figure for SRC, for the sudden-braking or the cruising tests."""
PAPER_ACCURACY = {
    "normal-braking": "99.92 (7794 of 7800: the six sudden-braking labels are its only errors, sec. V)",
    "sudden-braking": "not given (\"the results contain normal braking labels\", sec. V)",
    "cruising": "not given (a figure of one 40 s ride, sec. V)",
}


@dataclass
class Evaluation:
    """Everything one run measured; ``seconds`` is its wall time from simulation to the last peer."""

    protocol: Protocol
    data: dict[str, ScenarioData]
    trained: Trained
    naming: dict[str, tuple[Score, Score]]
    crc: dict[str, MethodRuns]
    kcrc: dict[str, MethodRuns]
    methods: dict[str, MethodRuns]
    peers: dict[str, MethodRuns]
    ride_models: RideModels
    seconds: float
    command: str
    machine: str
    date: str
    figures: dict[str, str]


def render(ev: Evaluation) -> str:
    """The whole ``report.md``."""
    sections = [_header(ev), _summary(ev), _protocol(ev), _training(ev), _accuracy(ev), _count(ev), _sudden_stops(ev),
                _per_class(ev), _confusions(ev), _latency(ev), _methods(ev), _peers(ev), _ride_models(ev),
                _figures(ev)]
    return "\n\n".join(s.rstrip() for s in sections) + "\n"


def headline(ev: Evaluation) -> list[str]:
    """A few lines for the terminal: headline accuracy per scenario and the paper's count."""
    lines = []
    for name in SCENARIOS:
        test = ev.data[name].test
        score = accuracy(ev.crc[HEADLINE].runs[name].labels.label, test.truth["label"])
        lines.append(f"{name}: {_pct(score)}% of {score.total} labelled test samples right ({HEADLINE} windows)")
    count = label_count(ev.crc[HEADLINE].runs["normal-braking"].labels.label, "sudden-braking")
    paper = PAPER["normal_sudden_labels"]
    lines.append(f"sudden-braking labels in the normal-braking tests: {count.correct} of {count.total} "
                 f"(paper: {paper.correct} of {paper.total})")
    return lines


# ---------------------------------------------------------------- sections

def _header(ev: Evaluation) -> str:
    quick = " (`--quick`: fewer experiments, not the paper's protocol)" if ev.protocol.quick else ""
    return f"""# spotfree evaluation: the paper's section V on the simulator{quick}

Command: `{ev.command}`; {ev.date}; {ev.machine}.
Wall time of the run: {ev.seconds:.0f} s (simulation, features, training, every classification, every peer, the
lateral and road models; figures and this report not included).

Every figure below was measured in this run; the paper's figures are quoted with their section."""


def _summary(ev: Evaluation) -> str:
    paper = PAPER["normal_sudden_labels"]
    nb = ev.crc[HEADLINE].runs["normal-braking"].labels.label
    nb_all, nb_away = _scores(ev, nb, "normal-braking")
    count = label_count(nb, "sudden-braking")
    ours_total = _total(ev, HEADLINE)[0]
    kernel = ev.kcrc[HEADLINE].runs["normal-braking"].labels.label
    k_all, k_away = _scores(ev, kernel, "normal-braking")
    k_count = label_count(kernel, "sudden-braking")
    k_total = _sum_accuracy(ev, ev.kcrc[HEADLINE])
    peers = ", ".join(f"{name} {_pct(_sum_accuracy(ev, runs))}%" for name, runs in ev.peers.items())
    speed = {m: 1000 * r.seconds / r.decisions for m, r in ev.methods.items()}
    ratios = ", ".join(f"{METHODS[m]} {speed[m]:.3g} s" for m in METHODS)
    paper_s = PAPER["seconds_per_1000"]
    return f"""## Summary

- Normal-braking tests, spotfree CRC_RLS with causal windows: {_pct(nb_all)}% of {nb_all.total} labels right
  ({_pct(nb_away)}% away from transitions); paper: {100 * (1 - paper.rate):.2f}% of {paper.total}.
- Sudden-braking labels inside the normal-braking tests: {count.correct} of {count.total}; paper: {paper.correct}
  of {paper.total}.
- Kernel CRC_RLS on the same dictionary (not in the paper; a scaled-down hard stop no longer explains a soft one):
  normal-braking tests {_pct(k_all)}% ({_pct(k_away)}% away from transitions), {k_count.correct} sudden-braking
  labels of {k_count.total}.
- All tests: spotfree CRC_RLS {_pct(ours_total)}%, kernel CRC_RLS {_pct(k_total)}% (no training label); peers
  trained with every label: {peers}.
- Time per 1000 windows: {ratios} (B_SRC / CRC_RLS = {speed["bsrc"] / speed["crc"]:.0f}); paper: CRC_RLS
  {paper_s["crc"]:g} s, B_SRC {paper_s["bsrc"]:g} s (ratio {paper_s["bsrc"] / paper_s["crc"]:.0f})."""


def _protocol(ev: Evaluation) -> str:
    p = ev.protocol
    rows = []
    for name in SCENARIOS:
        d = ev.data[name]
        lengths = [len(r) for _, r in d.test.experiments()]
        trained = f"experiment {TRAIN_EXPERIMENT}" if name in TRAINED_ON else "none"
        rows.append([name, str(p.repeats), trained, ", ".join(map(str, d.experiments)), str(len(d.test)),
                     f"{np.mean(lengths):.0f}", ", ".join(CLASSES[name])])
    model = ev.trained.learner.model_
    offset = model.window // 2
    table = _table(["scenario", "experiments", "trained on", "tested", "test samples", "mean ride (samples)",
                    "classes in the truth"], rows)
    return f"""## Protocol

Simulated with `spotfree.sim` (seed {p.seed}, {p.rate:g} Hz): {p.repeats} experiments (rides) per scenario.
The dictionary is trained without labels on experiment {TRAIN_EXPERIMENT} of the normal-braking file, declared
`{",".join(CLASSES["normal-braking"])}`, and of the sudden-braking file, declared `{",".join(CLASSES["sudden-braking"])}`
(the paper trains on one experiment of each braking state); the other experiments are the tests, and every cruising
ride (none is trained on). Paper: seven experiments per manoeuvre, six tests each, a mean of
{PAPER["experiment_samples"]} samples per experiment (sec. V).

{table}

Scoring: one label per sample against the simulator's hidden ground truth (`label`, from the rider's lean; never
read by training). Only labelled samples are scored: a window of {model.window} samples ({model.window / p.rate:g} s)
labels nothing before it is full, so with causal windows the first {model.window - 1} samples of every ride have no
label; with centred windows the first {model.window - 1 - offset} and the last {offset}.

- **causal** windows (headline): the window ending at a sample labels it, as the phone does live;
  **centred**: the window centred on it (offline, {offset} samples = {offset / p.rate:g} s later).
- **all**: every labelled sample. **away from transitions**: leaving out the {2 * round(TRANSITION_BAND * p.rate)}
  samples within +-{TRANSITION_BAND:g} s of every true label change (the last {round(TRANSITION_BAND * p.rate)} samples
  of a state and the first {round(TRANSITION_BAND * p.rate)} of the next), where a window holds two states.
- Classification: spotting-free CRC_RLS, no smoothing, no rejection."""


def _training(ev: Evaluation) -> str:
    learner = ev.trained.learner
    model = learner.model_
    columns = model.summary.get("columns_per_class", {})
    rows = [[c, str(columns.get(c, 0)), _pct(precision), _pct(recall)] for c, (precision, recall) in ev.naming.items()]
    warnings = "\n" + "".join(f"\n- warning: {w}" for w in learner.warnings_) if learner.warnings_ else ""
    return f"""## Training

The `braking` preset (`spotfree train --preset braking`: the general learner on `{model.representation}` windows of
`{",".join(model.channels)}`, {model.window} samples, with the ride prior), seed {ev.protocol.seed}:
{model.dictionary.shape[1]} dictionary columns in {ev.trained.seconds:.1f} s. Naming: how the learner named the
training windows against the hidden ground truth at each window's centre (precision: the windows it named the class
that are that class; recall: the class's windows it named so). Training never reads the truth.

{_table(["class", "columns", "naming precision %", "naming recall %"], rows)}{warnings}

![training](training.png)

Each row is a training experiment: its `{model.channels[0]}` channel, each window's centre coloured by the name the
learner gave it."""


def _accuracy(ev: Evaluation) -> str:
    rows = []
    for name in SCENARIOS:
        cells = [name, PAPER_ACCURACY[name]]
        for alignment in ALIGNMENTS:
            all_, away = _scores(ev, ev.crc[alignment].runs[name].labels.label, name)
            cells += [_pct(all_), _pct(away)]
        rows.append(cells)
    total = [_total(ev, alignment) for alignment in ALIGNMENTS]
    rows.append(["all tests", "-", *[_pct(s) for pair in total for s in pair]])
    return f"""## Accuracy per sample (spotfree CRC_RLS)

Per cent of labelled test samples whose label is the true class; the headline is causal windows.

{_table(["scenario", "paper", "causal: all", "causal: away from transitions", "centred: all",
         "centred: away from transitions"], rows)}"""


def _count(ev: Evaluation) -> str:
    paper = PAPER["normal_sudden_labels"]
    count = label_count(ev.crc[HEADLINE].runs["normal-braking"].labels.label, "sudden-braking")
    cells = [f"{c.correct} of {c.total} ({100 * c.rate:.3f}%)" for c in (paper, count)]
    return f"""## The paper's count: sudden-braking labels inside the normal-braking tests

Out of all labels of the normal-braking tests (a normal-braking ride holds no sudden stop, so each is a false alarm
of the ride assistant). Causal and centred windows give the same count: the same windows, each labelling one sample,
shifted by half a window.

{_table(["paper (sec. V)", "ours"], [cells])}"""


def _per_class(ev: Evaluation) -> str:
    rows = []
    for name in SCENARIOS:
        truth = ev.data[name].test.truth["label"]
        near = _near(ev, name)
        scores = []
        for alignment in ALIGNMENTS:
            label = ev.crc[alignment].runs[name].labels.label
            scores += [class_accuracy(label, truth, CLASSES[name]),
                       class_accuracy(np.where(near, "", label), truth, CLASSES[name])]
        rows += [[name, cls, str(int(np.sum(truth == cls))), *[_pct(s[cls]) for s in scores]] for cls in CLASSES[name]]
    return f"""## Accuracy per true class

Per cent of the labelled samples of a true class labelled as that class (its recall).

{_table(["scenario", "true class", "samples", "causal: all", "causal: away from transitions", "centred: all",
         "centred: away from transitions"], rows)}"""


def _confusions(ev: Evaluation) -> str:
    model_classes = list(ev.trained.learner.model_.classes)
    parts = ["## Confusion matrices (causal windows, all labelled samples)\n\nRows: true class; columns: label."]
    for name in SCENARIOS:
        truth = ev.data[name].test.truth["label"]
        rows_classes = list(CLASSES[name])
        classes = rows_classes + [c for c in model_classes if c not in rows_classes]
        counts = confusion_matrix(ev.crc[HEADLINE].runs[name].labels.label, truth, classes)
        rows = [[c, *map(str, counts[i])] for i, c in enumerate(classes) if c in rows_classes]
        parts.append(f"**{name}**\n\n" + _table(["true \\ label", *classes], rows))
    return "\n\n".join(parts)


def _latency(ev: Evaluation) -> str:
    rows = []
    for name in SCENARIOS:
        truth = ev.data[name].test.truth["label"]
        found = {a: onset_latency(ev.crc[a].runs[name].labels, truth) for a in ALIGNMENTS}
        for cls in CLASSES[name]:
            if cls not in found[HEADLINE]:
                rows.append([name, cls, "-", "not in the model", "-", "not in the model", "-"])
                continue
            cells = [name, cls, str(found[HEADLINE][cls].onsets)]
            for alignment in ALIGNMENTS:
                latency = found[alignment][cls]
                cells += [f"{latency.detected}", _seconds(latency.median)]
            rows.append(cells)
    return f"""## Decision latency

From each true onset of a class (a change of the ground truth to it inside a labelled stretch) to the start of the
run of labels that names it, found up to 1 s after the true run ends (`spotfree.classify.latency`): positive = late.
Median over the detected onsets; the paper quotes none.

{_table(["scenario", "class", "true onsets", "causal: detected", "causal: median delay",
         "centred: detected", "centred: median delay"], rows)}"""


def _methods(ev: Evaluation) -> str:
    rows, strides = [], []
    for method, runs in ev.methods.items():
        all_ = sum((accuracy(r.decided(), ev.data[n].test.truth["label"]) for n, r in runs.runs.items()), Score(0, 0))
        away = sum((accuracy(r.decided(), ev.data[n].test.truth["label"], ~_near(ev, n))
                    for n, r in runs.runs.items()), Score(0, 0))
        per_1000 = 1000 * runs.seconds / runs.decisions
        paper = PAPER["seconds_per_1000"].get(method)
        rows.append([runs.name, str(runs.decisions), _pct(all_), _pct(away), f"{runs.fit_seconds:.3f}",
                     f"{runs.seconds:.2f}", f"{per_1000:.3f}", "-" if paper is None else f"{paper:g}"])
    first = next(iter(ev.methods.values()))
    for name, run in first.runs.items():
        strides.append(f"{name}: stride {run.labels.meta['step']}, {run.decisions} windows")
    noted = _notes(ev.methods)
    paper_crc, paper_bsrc = PAPER["seconds_per_1000"]["crc"], PAPER["seconds_per_1000"]["bsrc"]
    return f"""## CRC_RLS vs SRC vs B_SRC on the same windows

The three classifiers of section IV-A on the trained dictionary, and two rules that are not in the paper: kernel
CRC_RLS (Gaussian kernel, `spotfree.classify.kcrc`) and the nearest-columns rule (mean distance to the 5 nearest
columns of each class); causal windows, one subsample of the tests for all of them (SRC
and B_SRC are too slow for every window): {"; ".join(strides)}. Only the samples those windows decide are
scored. Time: wall clock of the classification (windowing included), the classifier's fit (CRC_RLS: the operator
`(A^T A + lambda I)^-1 A^T`) apart. Paper: 1000 time samples in {paper_crc:g} s by CRC_RLS and {paper_bsrc:g} s by
B_SRC, in Matlab (sec. IV-A).

{_table(["method", "windows", "accuracy: all", "away from transitions", "fit (s)", "classify (s)",
         "s per 1000 windows", "paper: s per 1000"], rows)}{noted}"""


def _peers(ev: Evaluation) -> str:
    ours, kernel = ev.crc[HEADLINE], ev.kcrc[HEADLINE]
    entries = [("spotfree CRC_RLS (no labels; dictionary by spotting-free training)", ev.trained.seconds + ours.fit_seconds,
                ours),
               ("spotfree kernel CRC_RLS (no labels; the same dictionary)", ev.trained.seconds + kernel.fit_seconds,
                kernel)] + [(name, runs.fit_seconds, runs) for name, runs in ev.peers.items()]
    rows = []
    for name, fit, runs in entries:
        cells = [name, f"{fit:.1f}", f"{runs.seconds:.2f}", f"{1000 * runs.seconds / max(runs.decisions, 1):.3f}"]
        for scenario in SCENARIOS:
            all_, away = _scores(ev, runs.runs[scenario].labels.label, scenario)
            cells.append(f"{_pct(all_)} / {_pct(away)}")
        cells.append(_pct(_sum_accuracy(ev, runs)))
        rows.append(cells)
    noted = _notes(ev.peers)
    return f"""## Peers on the same tests

Trained on the same two training experiments, on the same channels and window, but given every training sample's
true label (the hand-marked pattern boundaries the paper's training does without): MiniRocket (aeon, ridge
classifier on n_kernels={ev.protocol.minirocket_kernels} convolution features) and a 1-nearest-neighbour window
classifier, both with causal windows;
ClaSP (aeon's ClaSP profile, binary segmentation per channel) segments each test ride without labels and names each
segment by the nearest training class centroid. Fit: training wall time (spotfree: dictionary training plus the
CRC_RLS operator; first calls include numba compilation where a method uses it); predict: labelling all tests.
Accuracy cells: all / away from transitions.

{_table(["method", "fit (s)", "predict (s)", "s per 1000 labels", *[f"{s}" for s in SCENARIOS], "all tests"],
        rows)}{noted}

The paper compares with no other method."""


def _ride_models(ev: Evaluation) -> str:
    ride = ev.ride_models
    parts = []
    for name, result in ride.scores.items():
        model = result.model
        spec = MODELS[name]
        goal = lambda s: "yes" if s.total and s.rate >= 0.98 else "no"  # noqa: E731
        rows = [[c, f"{s.correct} / {s.total}", _pct(s), goal(s), _pct(result.segmented[c]),
                 goal(result.segmented[c])] for c, s in result.per_class.items()]
        rows.append(["all", f"{result.overall.correct} / {result.overall.total}", _pct(result.overall), "",
                     _pct(result.segmented_overall), ""])
        warned = f"\n\nTraining warnings: {'; '.join(result.warnings)}." if result.warnings else ""
        detected = "".join(f"\n\n{_detections(c, result.detected[c], result.segmented_detected.get(c))}"
                           for c in spec.detections)
        kept = (f", {', '.join(spec.keep)} kept" if spec.keep else "") \
            + (f"; then the event vote outside {spec.background}" if spec.events else "") \
            + "".join(f"; then the event edges at {c} {level:g}" for c, level in spec.edges)
        parts.append(f"""### {name}

Channels {', '.join(model.channels)}; window {model.window} samples ({model.window / model.rate:.2f} s);
{model.dictionary.shape[1]} dictionary columns; classes named by the training: {', '.join(map(str, model.classes))}.
Offline vote: the segment vote at penalty {spec.segments:g}{kept}.

{_table(["true class", "right / samples (causal)", "causal (%)", ">= 98 %", "offline vote (%)", ">= 98 %"],
        rows)}{detected}{warned}""")
    models = "\n\n".join(parts)
    median, p99 = np.percentile(ride.stream.micros, [50, 99])
    verdict = "within" if median <= STREAM_GOAL_US else "over"
    return f"""## Lateral manoeuvres and road surface, and three models on one stream

Each model is trained spotting-free on this seed's simulated rides of four training riders, one ride per kind of
manoeuvre or road event and one without any, each declaring only the classes it holds
(`spotfree.evaluation.lateral_road`); it labels the rides of three held-out riders with causal windows and kernel
CRC_RLS, scored per true class (the goal: 98 % per class). The causal labels are what a live ride shows; the
segment vote (`spotfree classify --segments`, offline: it sees the whole ride) cuts each ride where the model's
channels change (PELT) and gives every segment the label most of its samples carry; the lateral model's event vote
(`--events straight`) then gives each run of turn labels, one turn or slalom, the label most of its samples carry,
and its event edges (`--edges yaw_rate=0.09`) move each turn's start and end to where the yaw rate crosses 0.09 rad/s
(the labels' convention starts a turn at 0.10 rad/s; no window named without labels can learn where).

{models}

### Cost per raw sample, three models together

The braking model above, the lateral and the road model in one `MultiModelStream` (one feature pass, each model its
own window), fed the held-out raw lateral rides one sample at a time ({ride.stream.samples} samples):

- median {median:.1f} us, p99 {p99:.1f} us per raw sample, {verdict} the {STREAM_GOAL_US:g} us budget;
- stream labels unlike the batch labels of the same rides: {ride.stream.differing}."""


def _sudden_stops(ev: Evaluation) -> str:
    """Sudden stops scored as events in every test, by each method that labels every sample."""
    methods = [(f"spotfree CRC_RLS ({a})", ev.crc[a]) for a in ALIGNMENTS]
    methods += [(f"spotfree kernel CRC_RLS ({a})", ev.kcrc[a]) for a in ALIGNMENTS]
    methods += [(name, runs) for name, runs in ev.peers.items()]
    rows = []
    for name, runs in methods:
        scores = {s: event_detection(runs.runs[s].labels.label, ev.data[s].test.truth["label"], "sudden-braking",
                                     ev.data[s].test.experiment, ev.data[s].test.rate) for s in SCENARIOS}
        total = sum(scores.values(), EventScore(0, 0, 0, 0.0))
        without = sum((v for s, v in scores.items() if not v.events), EventScore(0, 0, 0, 0.0))
        rows.append([name, f"{total.detected} / {total.events}", str(total.false_alarms), _fraction(total.precision),
                     _fraction(total.rate), _fraction(total.f1), f"{without.false_alarms_per_hour:.0f}"])
    return f"""## Sudden stops as events

Each run of true `sudden-braking` samples in a test ride is one sudden stop, detected when a run of
`sudden-braking` labels meets it within {EVENT_TOLERANCE:g} s (`spotfree.evaluation.metrics.event_detection`); a
run of labels that meets none is a false alarm. Precision = detected / (detected + false alarms), recall = detected /
stops; the last column counts the false alarms per hour of the rides without a sudden stop (the normal-braking and
cruising tests). Peers trained with every label beside.

{_table(["method", "stops detected", "false alarms", "precision", "recall", "F1",
         "false alarms per hour without stops"], rows)}"""


def _fraction(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.3f}"


def _detections(name: str, causal: EventScore, voted: EventScore | None) -> str:
    """The line that scores ``name`` as events (:func:`~spotfree.evaluation.metrics.event_detection`)."""
    def one(score: EventScore) -> str:
        return (f"{score.detected} of {score.events} detected ({100 * score.rate:.1f} %), "
                f"{score.false_alarms} false alarms ({score.false_alarms_per_hour:.0f} per hour of riding)")

    after = f"; after the offline vote {one(voted)}" if voted is not None else ""
    return (f"As events ({name} samples in a row are one event, detected by a run of {name} labels within "
            f"{EVENT_TOLERANCE:g} s of it): causal {one(causal)}{after}.")


def _figures(ev: Evaluation) -> str:
    images = "\n\n".join(f"![{name}]({path})" for name, path in ev.figures.items())
    return f"""## Results figures

Like the paper's results figures (sec. V: normal braking, sudden braking, cruising): the handlebar pitch angle
(attitude filter, degrees, positive nose down) of every test ride, each sample coloured by its causal CRC_RLS
label, the ground truth as a band along the top.

{images}"""


# ---------------------------------------------------------------- helpers

def _near(ev: Evaluation, scenario: str) -> np.ndarray:
    test = ev.data[scenario].test
    return near_transitions(test.truth["label"], test.experiment, test.rate)


def _scores(ev: Evaluation, label: np.ndarray, scenario: str) -> tuple[Score, Score]:
    truth = ev.data[scenario].test.truth["label"]
    return accuracy(label, truth), accuracy(label, truth, ~_near(ev, scenario))


def _total(ev: Evaluation, alignment: str) -> tuple[Score, Score]:
    pairs = [_scores(ev, ev.crc[alignment].runs[s].labels.label, s) for s in SCENARIOS]
    return sum((p[0] for p in pairs), Score(0, 0)), sum((p[1] for p in pairs), Score(0, 0))


def _sum_accuracy(ev: Evaluation, runs: MethodRuns) -> Score:
    """Accuracy over the labelled samples of every scenario's tests."""
    return sum((accuracy(r.labels.label, ev.data[s].test.truth["label"]) for s, r in runs.runs.items()), Score(0, 0))


def _notes(runs: dict[str, MethodRuns]) -> str:
    """The warnings the runs raised, one bullet each (empty when none)."""
    notes = sorted({note for r in runs.values() for note in r.notes})
    return "\n" + "".join(f"\n- warning: {note}" for note in notes) if notes else ""


def _pct(score: Score) -> str:
    return "-" if not score.total else f"{100 * score.rate:.2f}"


def _seconds(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:+.2f} s"


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)
