"""``spotfree evaluate``: the paper's section V on the simulator, written to a folder as report.md and figures.

:func:`evaluate` runs the protocol (:mod:`spotfree.evaluation.protocol`), the measurements
(:mod:`spotfree.evaluation.measure`), draws the figures and writes the report (:mod:`spotfree.evaluation.report`).
The folder is written atomically: everything goes to a temporary folder beside it first; a new folder is then
renamed into place, an existing one has each file replaced (other files in it are left alone).
"""

from __future__ import annotations

import os
import platform
import secrets
import shutil
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

import numpy as np

from spotfree.errors import InputError
from spotfree.evaluation.figures import confusion_figure, event_timeline, results_figure, training_figure
from spotfree.evaluation.hand import PEER_CHANNELS, PEER_WINDOW, evaluate_hand
from spotfree.evaluation.metrics import naming_scores
from spotfree.evaluation.measure import HEADLINE, MINIROCKET, MINIROCKET_OFFLINE, NEAREST, check_peers, crc_runs, \
    make_peers, method_runs, peer_runs
from spotfree.evaluation.protocol import SCENARIOS, Protocol, simulate, train_dictionary
from spotfree.evaluation.report import Evaluation, confusion_panels, event_rides, render
from spotfree.evaluation.ride_models import evaluate_ride_models
from spotfree.sim.scenarios import CLASSES

Progress = Callable[[str], None]


def evaluate(output: str | Path, seed: int = 0, quick: bool = False, progress: Progress | None = None) -> Evaluation:
    """Run the evaluation (``quick``: :meth:`Protocol.quick_run`) and write ``output``/report.md and its figures."""
    output = Path(output)
    check_output(output)
    check_peers()
    say = progress or (lambda message: None)
    protocol = Protocol.quick_run(seed) if quick else Protocol(seed=seed)
    start = time.perf_counter()
    say(f"simulating {protocol.repeats} experiments of {', '.join(SCENARIOS)}")
    data = simulate(protocol)
    say("training the dictionary (no labels)")
    trained = train_dictionary(data, protocol)
    model = trained.learner.model_
    say("classifying the tests with CRC_RLS (causal and centred windows)")
    crc = crc_runs(model, data)
    say("classifying the tests with kernel CRC_RLS (causal and centred windows)")
    kcrc = crc_runs(model, data, "kcrc")
    say("CRC_RLS vs SRC vs B_SRC on a subsample of windows")
    methods = method_runs(model, data, protocol.method_windows)
    say("peers: MiniRocket (causal and centred), 1-NN, ClaSP")
    peers = peer_runs(make_peers(model.channels, model.window, protocol), data)
    say("lateral and road models beside their MiniRocket peers, and the three models on one stream")
    ride_models = evaluate_ride_models(model, seed, lambda spec: {
        name: peer for name, peer in make_peers(spec.channels, spec.window, protocol, protocol.ride_train_step).items()
        if name in (MINIROCKET, MINIROCKET_OFFLINE)})
    say(f"the hand: trained on {protocol.hand_people[0]} people, tested on {protocol.hand_people[1]}, beside its peers")
    hand = evaluate_hand(*protocol.hand_people, seed=seed, peers={
        name: peer for name, peer in make_peers(PEER_CHANNELS, PEER_WINDOW, protocol, protocol.hand_train_step).items()
        if name in (MINIROCKET, NEAREST)})
    seconds = time.perf_counter() - start
    figures = {f"results: {name}": f"results-{name}.png" for name in SCENARIOS}
    ev = Evaluation(
        protocol=protocol, data=data, trained=trained, naming=naming_scores(
            trained.learner.window_labels_, trained.learner.window_ends_,
            [r.truth["label"] for r in trained.recordings], model.window, model.classes),
        crc=crc, kcrc=kcrc, methods=methods, peers=peers, ride_models=ride_models, hand=hand, seconds=seconds,
        command=f"spotfree evaluate -o {output} --seed {seed}" + (" --quick" if quick else ""),
        machine=machine_summary(), date=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), figures=figures,
    )
    say("drawing figures and writing the report")
    output.parent.mkdir(parents=True, exist_ok=True)
    staging = output.parent / f".{output.name}.{secrets.token_hex(6)}"
    staging.mkdir()  # mode 0o777 less the user's umask, as the folder it becomes
    classes = list(dict.fromkeys([c for name in SCENARIOS for c in CLASSES[name]] + list(model.classes)))
    try:
        training_figure(trained.learner, trained.recordings, staging / "training.png")
        for name, path in zip(SCENARIOS, figures.values()):
            results_figure(data[name].test, crc[HEADLINE].runs[name].labels, classes, staging / path,
                           f"{name} tests, CRC_RLS ({HEADLINE} windows)")
        for path, panels in confusion_panels(ev).items():
            confusion_figure(panels, staging / path)
        for path, (title, rides) in event_rides(ev).items():
            event_timeline(rides, title, staging / path)
        (staging / "report.md").write_text(render(ev), encoding="utf-8")
        _publish(staging, output)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return ev


def check_output(output: Path) -> None:
    """Refuse an output that exists and is not a folder."""
    if output.exists() and not output.is_dir():
        raise InputError(f"{output}: exists and is not a folder; give -o a folder (it is created if missing)")


def machine_summary() -> str:
    """CPU model, cores, load average, Python and numpy versions (for the report's header)."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            cpu = next(line.split(":", 1)[1].strip() for line in info if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    load = f", load average {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    return (f"{cpu}, {os.cpu_count()} cores{load}; {platform.system()} {platform.release()}; "
            f"Python {platform.python_version()}, numpy {np.__version__}")


def _publish(staging: Path, output: Path) -> None:
    """Move the staged files to ``output``: a rename of the whole folder when it is new, else file by file."""
    if not output.exists():
        os.replace(staging, output)
        return
    for path in sorted(staging.iterdir()):
        os.replace(path, output / path.name)
