"""The tracking service's JSON schema: field mapping to SI units, service messages, refused fields, round trip."""

import copy
import json

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.hand.frames import HAND_CHANNELS, frame_message, is_frame, parse_frame
from spotfree.sim.hand import simulate_hands

# A protocol v6 frame as the service sends it (values of a published frame; internal fields r/s/t, arm, bones and
# the interaction box included, as they appear on the wire). Pointables come in id order, not finger order.
SERVICE_FRAME = {
    "currentFrameRate": 110.845, "devices": [], "gestures": [], "id": 3571, "timestamp": 236771514099,
    "interactionBox": {"center": [0, 200, 0], "size": [235.247, 235.247, 147.751]},
    "r": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "s": 1, "t": [0, 0, 0],
    "hands": [{
        "armBasis": [[-0.709771, 0.0291785, -0.703828], [0.133888, 0.986517, -0.0941205],
                     [-0.691592, 0.161038, 0.704108]],
        "armWidth": 63.55, "confidence": 0.98494, "direction": [0.245866, 0.534613, -0.808541],
        "elbow": [-232.876, 143.868, 304.861], "grabStrength": 0.25, "id": 2,
        "palmNormal": [0.0292828, -0.837862, -0.545096], "palmPosition": [-25.9111, 124.847, 71.0508],
        "palmVelocity": [-0.30963, -1.88169, -0.271271], "palmWidth": 90.7472, "pinchStrength": 0.5,
        "r": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "s": 1.392, "sphereCenter": [-37.361, -119.627, -77.0083],
        "sphereRadius": 287.082, "stabilizedPalmPosition": [-25.0, 124.0, 71.0], "t": [0, 0, 0],
        "timeVisible": 1.2, "type": "right", "wrist": [-40.0, 110.0, 120.0],
    }],
    "pointables": [
        {"id": 20, "handId": 2, "type": 0, "tool": False, "extended": True, "tipPosition": [-80.0, 130.0, 40.0],
         "direction": [0.5, 0.2, -0.8], "length": 50.0, "width": 20.0, "btipPosition": [-79, 129, 41]},
        {"id": 21, "handId": 2, "type": 1, "tool": False, "extended": True, "tipPosition": [-40.0, 170.0, -10.0]},
        {"id": 22, "handId": 2, "type": 2, "tool": False, "extended": False, "tipPosition": [-20.0, 120.0, 50.0]},
        {"id": 23, "handId": 2, "type": 3, "tool": False, "extended": False, "tipPosition": [-5.0, 118.0, 52.0]},
        {"id": 24, "handId": 2, "type": 4, "tool": False, "extended": True, "tipPosition": [10.0, 140.0, 30.0]},
        {"id": 90, "handId": 2, "tool": True, "tipPosition": [0.0, 0.0, 0.0]},
        {"id": 31, "handId": 7, "type": 1, "tool": False, "extended": False, "tipPosition": [99.0, 99.0, 99.0]},
    ],
}


def test_fields_map_to_si_units_in_the_leap_frame():
    frame = parse_frame(SERVICE_FRAME, "frame")
    assert frame.timestamp == 236771514099 and frame.time == pytest.approx(236771.514099)
    assert frame.id == 3571 and frame.session == 1 and frame.truth is None
    (hand,) = frame.hands
    assert hand.side == "right" and hand.id == 2 and hand.confidence == pytest.approx(0.98494)
    np.testing.assert_allclose(hand.palm_position, [-0.0259111, 0.124847, 0.0710508])
    np.testing.assert_allclose(hand.palm_velocity, [-0.30963e-3, -1.88169e-3, -0.271271e-3])
    np.testing.assert_allclose(hand.palm_normal, [0.0292828, -0.837862, -0.545096])
    np.testing.assert_allclose(hand.direction, [0.245866, 0.534613, -0.808541])
    assert hand.palm_width == pytest.approx(0.0907472)
    assert (hand.grab, hand.pinch) == (0.25, 0.5)
    # fingers by their type code; the tool and the other hand's finger are not this hand's
    assert hand.extended.tolist() == [True, True, False, False, True]
    np.testing.assert_allclose(hand.tips[1], [-0.040, 0.170, -0.010])
    np.testing.assert_allclose(hand.tips[4], [0.010, 0.140, 0.030])
    vector = hand.vector()
    assert vector.shape == (len(HAND_CHANNELS),) and hand.complete
    assert vector[HAND_CHANNELS.index("palm_y")] == pytest.approx(0.124847)
    assert vector[HAND_CHANNELS.index("ext_pinky")] == 1.0
    assert vector[HAND_CHANNELS.index("tip_thumb_x")] == pytest.approx(-0.080)


def test_service_messages_are_not_frames_and_frames_without_hands_are():
    assert not is_frame({"serviceVersion": "2.3.1+33747", "version": 6})
    assert not is_frame({"event": {"type": "deviceConnect", "state": True}})
    assert is_frame(SERVICE_FRAME)
    empty = parse_frame({"id": 1, "timestamp": 5, "hands": [], "pointables": []}, "frame")
    assert empty.hands == ()


def test_null_and_nan_numbers_are_kept_as_nan_and_a_missing_finger_leaves_the_hand_incomplete():
    message = copy.deepcopy(SERVICE_FRAME)
    message["hands"][0]["palmPosition"] = [None, 124.8, float("nan")]
    hand = parse_frame(message, "frame").hands[0]
    assert np.isnan(hand.palm_position[[0, 2]]).all() and not hand.complete
    message = copy.deepcopy(SERVICE_FRAME)
    del message["pointables"][3]
    hand = parse_frame(message, "frame").hands[0]
    assert np.isnan(hand.tips[3]).all() and not hand.extended[3] and not hand.complete


@pytest.mark.parametrize(
    "change, words",
    [
        (lambda m: m["hands"][0].pop("grabStrength"), ["hands[0]", "'grabStrength'", "v6"]),
        (lambda m: m["hands"][0].update(palmPosition=[1, 2]), ["'palmPosition'", "3 numbers"]),
        (lambda m: m["hands"][0].update(palmWidth="wide"), ["'palmWidth'", "a number"]),
        (lambda m: m["pointables"][1].pop("type"), ["pointables[1].type", "0..4"]),
        (lambda m: m["pointables"][1].update(type=1.0), ["pointables[1].type"]),
        (lambda m: m["pointables"][2].update(extended="yes"), ["finger middle", "'extended'"]),
        (lambda m: m.pop("timestamp"), ["'timestamp'", "microseconds"]),
        (lambda m: m.update(hands={}), ["'hands'", "a list"]),
        (lambda m: m.update(session="one"), ["'session'"]),
    ],
    ids=["missing-field", "short-vector", "text", "finger-type", "float-type", "flag", "timestamp", "hands",
         "session"],
)
def test_unusable_fields_are_refused_with_where_and_what(change, words):
    message = copy.deepcopy(SERVICE_FRAME)
    change(message)
    with pytest.raises(InputError) as caught:
        parse_frame(message, "log.jsonl, line 7")
    text = str(caught.value)
    assert text.startswith("log.jsonl, line 7")
    for word in words:
        assert word in text


def test_simulated_frames_survive_the_json_round_trip():
    frames = simulate_hands(people=1, seed=2, rounds=1)[:400]
    for frame in frames:
        back = parse_frame(json.loads(json.dumps(frame_message(frame))), "frame")
        assert (back.timestamp, back.id, back.session, back.truth) == (frame.timestamp, frame.id, 1, frame.truth)
        assert len(back.hands) == len(frame.hands)
        for a, b in zip(back.hands, frame.hands):
            np.testing.assert_allclose(a.vector(), b.vector(), atol=1e-6)
            assert (a.side, a.id) == (b.side, b.id)
    assert any(not f.hands for f in simulate_hands(people=1, seed=2, rounds=1))
