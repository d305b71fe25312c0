"""Hand-tracking logs: simulator round trip, grid and ground truth, and the ride path's rules for bad frames."""

import json

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.hand.frames import HAND_CHANNELS, Hand, HandFrame, frame_message
from spotfree.hand.log import HAND_MAX_GAP, frames_to_recording, read_hand_log, write_hand_log
from spotfree.sim.hand import simulate_hands

PERIOD_US = 9000  # 111 frames per second


def hand(t: float, side: str = "right", confidence: float = 0.9) -> Hand:
    """A hand moving right at 10 mm/s, palm down, index extended."""
    return Hand(
        palm_position=np.array([0.01 * t, 0.2, 0.0]), palm_normal=np.array([0.0, -1.0, 0.0]),
        direction=np.array([0.0, 0.0, -1.0]), palm_velocity=np.array([0.01, 0.0, 0.0]), palm_width=0.085,
        grab=0.2, pinch=0.1, extended=np.array([False, True, False, False, False]),
        tips=np.tile([0.01 * t, 0.2, -0.08], (5, 1)), side=side, confidence=confidence,
    )


def frames(count: int = 300, absent: range = range(0), session: int = 1, start: int = 10**8) -> list[HandFrame]:
    """``count`` frames 9 ms apart; those with an index in ``absent`` have no hand."""
    out = []
    for k in range(count):
        stamp = start + k * PERIOD_US
        out.append(HandFrame(stamp, () if k in absent else (hand(stamp * 1e-6),), id=k, session=session))
    return out


def write_lines(path, messages, end="\n"):
    path.write_text("\n".join(m if isinstance(m, str) else json.dumps(m) for m in messages) + end)
    return path


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    sim = simulate_hands(people=2, seed=4, rounds=1)
    path = tmp_path_factory.mktemp("hand") / "sim.jsonl"
    write_hand_log(sim, path)
    return sim, read_hand_log(path)


# --- simulator round trip ---------------------------------------------------------------------------------------


def test_simulated_log_reads_as_one_experiment_per_session_on_a_20_hz_grid(simulated):
    sim, rec = simulated
    assert rec.rate == 20.0 and tuple(rec.channels) == HAND_CHANNELS
    assert set(rec.truth) == {"state", "label", "person", "pace"}
    pace = rec.truth["pace"].astype(float)
    assert np.all(pace[rec.truth["state"] == "posture"] == 0.0) and pace.max() > 0.99
    assert np.unique(rec.experiment).tolist() == [1, 2]
    for number, part in rec.experiments():
        np.testing.assert_allclose(np.diff(part.time), 0.05, atol=1e-9)
        assert set(part.truth["person"]) == {str(number)}
    assert rec.meta["frames"] == len(sim) and rec.meta["with_hand"] == sum(1 for f in sim if f.hands)
    assert all(100 <= r <= 120 for r in rec.meta["native_rates"].values())


def test_channels_and_truth_agree_with_the_frames(simulated):
    sim, rec = simulated
    t = np.array([f.time for f in sim])
    seen = np.array([bool(f.hands) for f in sim])
    palm = np.array([f.hands[0].palm_position if f.hands else [np.nan] * 3 for f in sim])
    labels = np.array([f.truth["label"] for f in sim])
    ok = rec.valid()
    for axis, name in enumerate(("palm_x", "palm_y", "palm_z")):
        expected = np.interp(rec.time[ok], t[seen], palm[seen, axis])
        # anti-aliasing low-pass against plain interpolation: they differ only by noise and fast motion (mm)
        assert np.percentile(np.abs(rec.channels[name][ok] - expected), 99) < 3e-3
    nearest = np.abs(rec.time[:, None] - t[None, :]).argmin(axis=1)
    assert np.mean(rec.truth["label"] == labels[nearest]) == 1.0
    assert np.mean(rec.truth["state"] == "gesture") > 0.15


def test_gaps_are_exactly_the_long_stretches_without_a_hand(simulated):
    sim, rec = simulated
    expected = []
    for session in (1, 2):
        part = [f for f in sim if f.session == session]
        t = np.array([f.time for f in part])
        seen = np.flatnonzero([bool(f.hands) for f in part])
        steps = np.diff(t[seen])
        expected += [(t[seen][i], t[seen][i + 1]) for i in np.flatnonzero(steps > HAND_MAX_GAP)]
    assert expected, "the simulator should lose the hand for longer than max_gap at least once"
    got = np.array([(g.start, g.end) for g in rec.gaps])
    assert got.shape == (len(expected), 2)
    np.testing.assert_allclose(got, np.array(expected), rtol=1e-6)
    for gap in rec.gaps:
        inside = (rec.time > gap.start) & (rec.time < gap.end)
        assert inside.any() and np.isnan(rec.array()[inside]).all()
    assert (~rec.valid()).sum() == sum(((rec.time > g.start) & (rec.time < g.end)).sum() for g in rec.gaps)


def test_same_frames_same_recording(simulated, tmp_path):
    sim, rec = simulated
    write_hand_log(sim, tmp_path / "again.jsonl")
    again = read_hand_log(tmp_path / "again.jsonl")
    np.testing.assert_array_equal(again.array(), rec.array())
    np.testing.assert_array_equal(again.truth["label"], rec.truth["label"])


# --- frames without a hand, NaN, order, JSON ------------------------------------------------------------------


def test_a_short_loss_is_bridged_and_a_long_one_is_a_gap(tmp_path):
    short = frames(absent=range(100, 108))  # 72 ms
    rec = frames_to_recording(short)
    assert rec.gaps == [] and rec.valid().all()
    long = frames(absent=range(100, 150))  # 0.45 s
    rec = frames_to_recording(long)
    (gap,) = rec.gaps
    assert gap.start == pytest.approx(short[99].time) and gap.end == pytest.approx(short[150].time)
    assert (~rec.valid()).sum() == 9  # the grid samples 100.90 .. 101.30 s, strictly inside 100.891 .. 101.35 s
    assert rec.meta["with_hand"] == 250 and rec.meta["frames"] == 300


def test_frames_without_a_hand_at_the_ends_are_reported(tmp_path):
    rec = frames_to_recording(frames(absent=range(0, 40)), source="x.jsonl")
    assert rec.time[0] == pytest.approx(frames()[40].time)
    assert any("no hand in the first 0.36 s" in w for w in rec.meta["warnings"])


def test_nan_in_a_hand_is_a_missing_frame_and_said_so(tmp_path):
    messages = [frame_message(f) for f in frames()]
    for k in (50, 51):
        messages[k]["hands"][0]["palmVelocity"] = [float("nan"), 0.0, 0.0]
    del messages[60]["pointables"][2]
    rec = read_hand_log(write_lines(tmp_path / "nan.jsonl", messages))
    assert rec.valid().all() and rec.gaps == []
    assert any("3 frame(s) whose hand lacks a finger or holds NaN" in r for r in rec.meta["repairs"])
    assert rec.meta["with_hand"] == 297


def test_a_few_frames_out_of_order_are_sorted_and_repeats_dropped(tmp_path):
    messages = [frame_message(f) for f in frames()]
    messages[100], messages[101] = messages[101], messages[100]
    messages.insert(200, messages[199])
    rec = read_hand_log(write_lines(tmp_path / "order.jsonl", messages))
    reference = frames_to_recording(frames())
    np.testing.assert_allclose(rec.array(), reference.array(), atol=1e-6)
    assert any("sorted 1 frame(s)" in r for r in rec.meta["repairs"])
    assert any("dropped 1 frame(s) repeating" in r for r in rec.meta["repairs"])


def test_many_frames_out_of_order_are_refused_with_the_line(tmp_path):
    messages = [frame_message(f) for f in frames()]
    messages[150:] = messages[150:][::-1]
    path = write_lines(tmp_path / "backwards.jsonl", [{"serviceVersion": "2.3.1", "version": 6}, *messages])
    with pytest.raises(InputError, match=r"backwards.jsonl, line 153: timestamp .* out of order"):
        read_hand_log(path)


def test_malformed_json_is_refused_with_the_line_number(tmp_path):
    lines = [json.dumps(frame_message(f)) for f in frames(20)]
    lines[6] = lines[6][:40]
    with pytest.raises(InputError, match=r"bad.jsonl, line 7: not valid JSON"):
        read_hand_log(write_lines(tmp_path / "bad.jsonl", lines))
    lines[6] = '{"id": 6, "timestamp": "soon", "hands": []}'
    with pytest.raises(InputError, match=r"line 7: field 'timestamp'"):
        read_hand_log(write_lines(tmp_path / "bad.jsonl", lines))


def test_an_unfinished_last_line_is_dropped_and_said_so(tmp_path):
    lines = [json.dumps(frame_message(f)) for f in frames(50)]
    lines[-1] = lines[-1][:55]
    rec = read_hand_log(write_lines(tmp_path / "cut.jsonl", lines, end=""))
    assert rec.meta["frames"] == 49
    assert any("unfinished last line 50" in r for r in rec.meta["repairs"])


def test_service_messages_and_blank_lines_are_skipped(tmp_path):
    messages = [{"serviceVersion": "2.3.1+33747", "version": 6}, "", *map(frame_message, frames(100))]
    messages.insert(50, {"event": {"type": "deviceConnect", "state": True}})
    rec = read_hand_log(write_lines(tmp_path / "service.jsonl", messages))
    assert rec.meta["frames"] == 100 and rec.gaps == []


@pytest.mark.parametrize(
    "content, message",
    [
        ("", "no frames"),
        ('{"serviceVersion": "2.3.1", "version": 6}\n', "no frames"),
        ("[1, 2]\n", "must be a JSON object"),
    ],
)
def test_files_without_frames_are_refused(tmp_path, content, message):
    path = tmp_path / "empty.jsonl"
    path.write_text(content)
    with pytest.raises(InputError, match=message):
        read_hand_log(path)


def test_a_log_without_usable_hands_is_refused():
    with pytest.raises(InputError, match="0 frame.* with a usable hand"):
        frames_to_recording(frames(absent=range(300)), source="nohand.jsonl")


def test_sessions_become_experiments_and_must_be_contiguous():
    rec = frames_to_recording(frames(session=3) + frames(session=5, start=2 * 10**8))
    assert np.unique(rec.experiment).tolist() == [3, 5]
    scattered = frames(session=3) + frames(10, session=4, start=2 * 10**8) + frames(session=3, start=3 * 10**8)
    with pytest.raises(InputError, match="line 311: session 3 starts again"):
        frames_to_recording(scattered)


def test_the_side_chooses_the_hand_and_confidence_breaks_ties():
    both = [HandFrame(f.timestamp, (hand(f.time, "left", 0.6), hand(f.time + 10.0, "right", 0.8)), f.id)
            for f in frames()]
    left = frames_to_recording(both, side="left")
    right = frames_to_recording(both, side="right")
    best = frames_to_recording(both)
    assert right.channels["palm_x"][0] == pytest.approx(left.channels["palm_x"][0] + 0.1, abs=1e-9)
    np.testing.assert_array_equal(best.array(), right.array())
    with pytest.raises(InputError, match="side 'both'"):
        frames_to_recording(both, side="both")
