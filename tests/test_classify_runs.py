"""Events from a label stream: runs of an active state, long enough, named by their vote; streaming equals batch."""

import numpy as np
import pytest

from spotfree.classify.runs import RunEvent, RunEvents, run_events, vote
from spotfree.errors import InputError


def test_a_run_is_one_event_named_by_its_vote_and_blips_are_dropped():
    active = np.array([0, 1, 1, 1, 1, 0, 1, 0, 1, 1, 1], dtype=bool)
    label = np.array(["p", "a", "b", "b", "a", "p", "c", "p", "d", "e", "e"])
    # the first run's label flickers a-b-b-a: still one event; the one-sample blip at 6 is no event at 2 samples
    assert run_events(active, label, min_samples=2) == [RunEvent("a", 1, 5), RunEvent("e", 8, 11)]
    assert run_events(active, label) == [RunEvent("a", 1, 5), RunEvent("c", 6, 7), RunEvent("e", 8, 11)]
    assert vote(["x", "y", "y", "x"]) == "x" and vote(["x", "y", "y"]) == "y"  # ties: the first in the run


def test_a_run_never_spans_two_experiments():
    active = np.ones(6, dtype=bool)
    label = np.array(list("aabbbb"))
    assert run_events(active, label, 1, experiment=np.array([1, 1, 1, 2, 2, 2])) == [
        RunEvent("a", 0, 3), RunEvent("b", 3, 6)]
    assert run_events(active, label, 4, experiment=np.array([1, 1, 2, 2, 2, 2])) == [RunEvent("b", 2, 6)]


@pytest.mark.parametrize("min_samples", [1, 2, 4])
def test_streaming_gives_the_batch_events_each_once_its_run_has_ended(min_samples):
    rng = np.random.default_rng(min_samples)
    active = rng.random(400) < 0.6
    label = rng.choice(list("abc"), 400)
    stream = RunEvents(min_samples)
    found = []
    for i, (a, name) in enumerate(zip(active, label)):
        event = stream.update(bool(a), str(name))
        if event is not None:
            assert event.stop == i and not a  # known at the first sample after the run
            found.append(event)
    last = stream.finish()
    found += [last] if last is not None else []
    expected = run_events(active, label, min_samples)
    assert found == expected and all(e.stop - e.start >= min_samples for e in expected)
    assert len(expected) <= len(run_events(active, label, 1))


def test_bad_arguments_are_refused_with_what_to_give():
    with pytest.raises(InputError, match="min_samples"):
        RunEvents(0)
    with pytest.raises(InputError, match="one label per sample"):
        run_events(np.ones(3, dtype=bool), np.array(["a", "b"]))
