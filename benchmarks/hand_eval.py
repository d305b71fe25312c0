"""Hand posture and gesture recognition on held-out simulated people: the paper's six test runs, in report form.

Usage: python benchmarks/hand_eval.py [--train-people 4] [--test-people 6] [--seed 0]
Prints Markdown (accuracy per run and stage, confusion matrices, command latency, streaming speed) for
BENCHMARKS.md and docs/hand.md.
"""

from __future__ import annotations

import argparse
import datetime

from classifier_timing import machine

from spotfree.hand.evaluation import evaluate_hand, hand_report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train-people", type=int, default=4)
    parser.add_argument("--test-people", type=int, default=6)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(f"`python benchmarks/hand_eval.py --train-people {args.train_people} --test-people {args.test_people} "
          f"--seed {args.seed}`, {datetime.date.today()}, {machine()}")
    print()
    ev = evaluate_hand(args.train_people, args.test_people, args.seed)
    print(hand_report(ev))


if __name__ == "__main__":
    main()
