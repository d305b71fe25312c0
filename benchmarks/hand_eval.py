"""Hand posture and gesture recognition on held-out simulated people: the paper's six test runs, in report form.

Usage: python benchmarks/hand_eval.py [--train-people 8] [--test-people 6] [--seed 0]
       python benchmarks/hand_eval.py --grid     stage 1 alone for several channel sets and windows, scored on six
                                                 development people (seed 1, people 201..), not the test people
Prints Markdown (accuracy per run, mode and stage, collars and observable onsets, gestures as events, the supervised
MiniRocket and 1-NN peers beside the recogniser, where gestures are lost, confusion matrices, command latency,
streaming speed; or the grid) and writes it, under the command, the machine and the date, to
``benchmarks/results/hand_eval.md`` (``hand_eval_grid.md`` with ``--grid``). ``--no-peers`` leaves the peers out.
"""

from __future__ import annotations

import argparse

from machine import results_file
from spotfree.evaluation.hand import PEER_CHANNELS, PEER_WINDOW, evaluate_hand, hand_report, state_grid
from spotfree.evaluation.measure import MINIROCKET, NEAREST, make_peers
from spotfree.evaluation.protocol import Protocol
from spotfree.sim.hand import TRAINING_PEOPLE

GRID = [(("speed", "turn", "flex"), 4), (("speed", "turn"), 3), (("speed", "turn"), 4), (("speed", "turn"), 5)]
"""Stage-1 settings compared by --grid: (channels, window in samples)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train-people", type=int, default=TRAINING_PEOPLE)
    parser.add_argument("--test-people", type=int, default=6)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--grid", action="store_true", help="compare stage-1 settings on development people")
    parser.add_argument("--no-peers", action="store_true", help="leave out the supervised peers")
    args = parser.parse_args()
    if args.grid:
        with results_file("hand_eval_grid", "Hand recognition, stage 1: channel sets and windows on development "
                          "people", preformatted=True):
            table = state_grid(GRID, args.train_people, seed=args.seed)
            print(table.to_string(index=False, float_format=lambda x: f"{100 * x:.2f} %"))
        return
    with results_file("hand_eval", "Hand postures and gestures on held-out simulated people"):
        protocol = Protocol(seed=args.seed)
        made = {} if args.no_peers else make_peers(PEER_CHANNELS, PEER_WINDOW, protocol, protocol.hand_train_step)
        peers = {name: peer for name, peer in made.items() if name in (MINIROCKET, NEAREST)}
        print(hand_report(evaluate_hand(args.train_people, args.test_people, args.seed, peers=peers)))


if __name__ == "__main__":
    main()
