"""Decision latency: delays from true onsets to labels, signed, per class; causal windows name manoeuvres later."""

import numpy as np
import pytest
from classify_fixtures import model, raw  # noqa: F401 (fixtures)

from spotfree.classify.batch import Labels
from spotfree.classify.latency import decision_latency, onset_latency
from spotfree.errors import InputError
from spotfree.io.recording import Recording


def labels_of(text, experiment=None):
    label = np.array(["" if c == "." else c for c in text], dtype=object)
    return Labels(time=np.arange(len(text)) / 20.0, label=label, rate=20.0, experiment=experiment,
                  meta={"classes": ["a", "b"]})


def test_delays_are_signed_per_class_and_missed_onsets_are_counted():
    truth = np.array(list("aaaaaaaaaabbbbbbbbbbaaaaaaaaaabbaaaaaaaa"))
    late = onset_latency(labels_of("aaaaaaaaaaaaabbbbbbbbbaaaaaaaaaaaaaaaaaa"), truth, tolerance=0.1)
    assert late["b"].onsets == 2 and late["b"].detected == 1  # the 2-sample b at 30 is never labelled
    np.testing.assert_allclose(late["b"].delays, [3 / 20])
    np.testing.assert_allclose(late["a"].delays, [2 / 20, -2 / 20])  # a at 32: labelled a at its onset,
    # traced back to the start of the missed b run (no further)
    early = onset_latency(labels_of("aaaaaaaabbbbbbbbbbbbaaaaaaaaaaaabbbaaaaa"), truth)
    np.testing.assert_allclose(early["b"].delays, [-2 / 20, 2 / 20])
    assert early["b"].median == pytest.approx(0.0)


def test_onsets_are_counted_only_where_there_are_labels():
    truth = np.array(list("aaaabbbbbbaaaa"))
    labels = onset_latency(labels_of("aaaa......aaaa"), truth)
    assert labels["b"].onsets == 0 and np.isnan(labels["b"].median)
    assert labels["a"].onsets == 0  # the truth changes inside the gap, not inside a labelled stretch


def test_causal_windows_name_manoeuvres_later_than_centred_ones(model, raw):
    ride = raw.select_experiment(2)
    latency = decision_latency(model, ride)
    for name in ("normal-braking", "sudden-braking"):
        causal, centred = latency["causal"][name], latency["centred"][name]
        print(f"{name}: median delay causal {causal.median:.2f} s, centred {centred.median:.2f} s "
              f"({causal.detected}/{causal.onsets} onsets)")
        assert causal.detected == causal.onsets > 0
        assert causal.median > centred.median
        assert 0 < causal.median <= model.window / model.rate
    with pytest.raises(InputError, match="'label'"):
        decision_latency(model, Recording(ride.time, ride.channels, ride.rate))


def test_truth_of_another_length_is_refused():
    with pytest.raises(InputError, match="truth has 3 samples"):
        onset_latency(labels_of("aaaa"), np.array(list("aaa")))
