"""Hand-tracking simulator: people hold the five deictic postures and move between them (the eight gestures) over
a Leap Motion-class tracker, which reports frames with tracking noise, jittered timing and lost frames.

:func:`simulate_hands` returns :class:`~spotfree.hand.frames.HandFrame` objects, one session per person, each
with ground truth ``{"state": "posture"|"gesture", "label": ..., "person": ..., "pace": ...}`` (``pace``:
the palm's path speed relative to the movement's peak, :func:`pace`; 0 in a posture). Model (docs/hand.md has the
numbers and their sources):

* **person** (:func:`draw_person`): hand size (scale of a 85 mm palm), neutral palm position, posture style
  (pointing with the index, with two fingers, or with the open hand; pointing angles; how far the hand is raised for
  ``stop`` and ``backward``), movement time, hold time, path curvature, speed-profile skew, when the fingers move
  within a movement, postural sway and tremor.
* **protocol** (``"test"``): a calibration hold in ``straight``, then ``rounds`` times each of ``left``, ``right``,
  ``stop``, ``backward`` in random order, each reached from ``straight`` and left back to it, so that each of the
  eight gestures ``straight-to-X`` / ``X-to-straight`` occurs ``rounds`` times; every hold varies around the
  person's posture by a few mm and degrees. ``"training"``: nine sessions per person
  (:data:`~spotfree.hand.vocabulary.TRAINING_TASKS`): a still hold, one move out to each posture, and ``rounds``
  round trips to each, so that evidence across sessions tells the postures and the gestures apart without marking
  where any of them starts.
* **movement**: minimum-jerk (Flash & Hogan 1985) ``s(u) = 10 u^3 - 15 u^4 + 6 u^5`` of the warped time ``u =
  tau^gamma``, ``tau = (t - t0) / T``: palm position ``p_a + (p_b - p_a) s + arc sin(pi s)``, orientation by
  spherical interpolation at ``s``, finger curl by minimum jerk inside a sub-interval of the movement. ``T`` grows
  with the rotation angle between the postures. Postural sway (0.1-1 Hz) and a 8-12 Hz tremor ride on top.
* **tracker**: frames at 100-120 Hz with 5 % interval jitter, 1 % of frames never sent, tracking-loss episodes
  (frames with no hand) of 0.03-0.5 s about every 15 s, position noise (white plus a slowly drifting bias),
  orientation, velocity, fingertip and strength noise, extended flags decided on the noisy curl.

The hand frame used here has ``u`` toward the thumb, ``d`` toward the fingers and ``n`` out of the palm
(``u = d x n``); a posture's rotation maps it into the Leap frame (x right, y up, z toward the user). Same seed,
same frames: person ``k`` draws from ``numpy.random.SeedSequence([seed, k, stream])``, so a person is the same
whichever ``people`` and ``first`` select it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from spotfree.errors import InputError
from spotfree.hand.frames import Hand, HandFrame
from spotfree.hand.vocabulary import POSTURES, TRAINING_TASKS

STREAMS = ("person", "plan", "motion", "tracker", "clock")

PROTOCOLS = ("test", "training")
TRAINING_PEOPLE = 8
"""People whose training protocol ``spotfree hand train`` simulates when given no log, and the evaluation trains on
(``benchmarks/hand_eval.py`` scores the choice)."""

PALM_WIDTH = 0.085
"""m, palm width of a hand of scale 1."""
KNUCKLES = np.array([[0.030, -0.020], [0.028, 0.040], [0.008, 0.045], [-0.012, 0.042], [-0.030, 0.035]])
"""m, base joint of each finger (thumb: carpometacarpal; others: knuckle) in the palm plane, ``(u, d)``."""
SEGMENTS = np.array([
    [0.045, 0.032, 0.025], [0.040, 0.022, 0.018], [0.045, 0.027, 0.019], [0.042, 0.026, 0.019],
    [0.033, 0.019, 0.017],
])
"""m, the three segment lengths of each finger from its base joint to the tip, thumb to pinky."""
SPLAY = np.deg2rad([40.0, 8.0, 0.0, -7.0, -15.0])
"""Angle of each open finger from ``d`` toward ``u`` (toward the thumb); a curled finger splays 60 % less."""
FLEX = np.deg2rad([[25.0, 35.0, 40.0], [90.0, 100.0, 70.0], [90.0, 100.0, 70.0], [90.0, 100.0, 70.0],
                   [90.0, 100.0, 70.0]])
"""Flexion of the three joints of each finger at curl 1 (fist), toward the palm side ``n``; linear in curl."""

_STRAIGHT = Rotation.from_matrix([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])
"""Hand frame (u, d, n) -> Leap frame for a flat right hand, palm down, fingers forward (away from the user)."""
_POINTING_CURL = {
    "index": [0.70, 0.05, 0.90, 0.90, 0.90],
    "two": [0.70, 0.05, 0.05, 0.90, 0.90],
    "open": [0.15, 0.05, 0.05, 0.05, 0.08],
}
_CURL = {"stop": [0.10, 0.03, 0.03, 0.03, 0.05], "backward": [0.20, 0.10, 0.10, 0.12, 0.15]}


def minimum_jerk(u: np.ndarray) -> np.ndarray:
    """``s(u) = 10 u^3 - 15 u^4 + 6 u^5`` for ``u`` clipped to 0..1: rest to rest with zero end accelerations."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u**2)


def pace(tau: np.ndarray, skew: float) -> np.ndarray:
    """How fast a movement of speed-profile skew ``skew`` (``gamma``) covers its path at time ``tau`` (0..1) of it,
    relative to its peak: ``d s(tau^gamma) / d tau = 30 gamma u^a (1 - u)^2`` with ``u = tau^gamma`` and
    ``a = 3 - 1 / gamma``, divided by its maximum, reached at ``u = a / (a + 2)`` (0 at both ends, 1 at the peak);
    the truth of where a gesture is observable."""
    a = 3.0 - 1.0 / skew
    u = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0) ** skew
    peak = a / (a + 2.0)
    return u**a * (1.0 - u) ** 2 / (peak**a * (1.0 - peak) ** 2)


@dataclass(frozen=True)
class Pose:
    """A hand configuration: palm ``position`` (3,) m relative to the neutral (Leap frame), ``rotation`` hand
    frame -> Leap frame, finger ``curl`` (5,) from 0 (extended) to 1 (fist)."""

    position: np.ndarray
    rotation: Rotation
    curl: np.ndarray


@dataclass(frozen=True)
class Person:
    """One simulated person (see :func:`draw_person`); lengths in m, times in s, angles in rad."""

    number: int
    scale: float
    neutral: np.ndarray
    style: str
    poses: dict[str, Pose]
    move_time: float
    hold_time: float
    skew: float
    arc: np.ndarray
    finger_window: tuple[float, float]
    sway: float
    sway_angle: float
    tremor: float
    tremor_frequency: float


@dataclass(frozen=True)
class TrackerSpec:
    """The tracker's timing and noise (SI units): frame rate range (Hz, one draw per session), relative interval
    jitter, share of frames never sent, tracking-loss episodes per second and their duration range, and the
    standard deviations of its errors."""

    frame_rate: tuple[float, float] = (100.0, 120.0)
    jitter: float = 0.05
    drop: float = 0.01
    loss_rate: float = 1.0 / 15.0
    loss_duration: tuple[float, float] = (0.03, 0.5)
    position_noise: float = 0.5e-3
    position_bias: float = 1.0e-3
    bias_time: float = 2.0
    angle_noise: float = np.deg2rad(1.5)
    velocity_noise: float = 0.005
    tip_noise: float = 1.0e-3
    strength_noise: float = 0.03
    curl_noise: float = 0.05


def draw_person(seed: int, number: int) -> Person:
    """Person ``number`` of the population of ``seed``: hand, neutral, posture style and movement habits."""
    rng = _rng(seed, number, "person")
    style = str(rng.choice(list(_POINTING_CURL)))
    yaw_left, yaw_right = np.deg2rad(rng.uniform(45.0, 80.0, 2))
    targets = {
        "straight": (np.zeros(3), Rotation.identity()),
        "left": (_mm(rng.uniform(-45, -15), rng.uniform(-5, 10), rng.uniform(-10, 10)),
                 Rotation.from_rotvec([0.0, yaw_left, 0.0])),
        "right": (_mm(rng.uniform(15, 45), rng.uniform(-5, 10), rng.uniform(-10, 10)),
                  Rotation.from_rotvec([0.0, -yaw_right, 0.0])),
        "stop": (_mm(rng.uniform(-10, 10), rng.uniform(25, 60), rng.uniform(-30, 0)),
                 Rotation.from_rotvec([np.deg2rad(rng.uniform(70, 100)), 0.0, 0.0])),
        "backward": (_mm(rng.uniform(-10, 10), rng.uniform(15, 45), rng.uniform(15, 45)),
                     Rotation.from_rotvec([0.0, np.pi - np.deg2rad(rng.uniform(20, 40)), 0.0])
                     * Rotation.from_rotvec([np.deg2rad(rng.uniform(70, 100)), 0.0, 0.0])),
    }
    poses = {}
    for name, (position, turn) in targets.items():
        curl = _POINTING_CURL[style] if name in ("straight", "left", "right") else _CURL[name]
        habit = Rotation.from_rotvec(rng.normal(0.0, np.deg2rad(5.0), 3))
        poses[name] = Pose(position, habit * turn * _STRAIGHT, np.clip(np.add(curl, rng.normal(0, 0.04, 5)), 0, 1))
    start = rng.uniform(0.0, 0.3)
    return Person(
        number=number, scale=rng.uniform(0.85, 1.15),
        neutral=_mm(rng.uniform(-30, 30), rng.uniform(150, 250), rng.uniform(-20, 40)),
        style=style, poses=poses, move_time=rng.uniform(0.5, 0.9), hold_time=rng.uniform(1.0, 2.5),
        skew=rng.uniform(0.8, 1.25), arc=_mm(rng.normal(0, 5), rng.uniform(5, 25), rng.normal(0, 5)),
        finger_window=(start, rng.uniform(start + 0.4, 1.0)), sway=rng.uniform(1.5e-3, 3e-3),
        sway_angle=np.deg2rad(rng.uniform(1.0, 2.0)), tremor=rng.uniform(0.1e-3, 0.4e-3),
        tremor_frequency=rng.uniform(8.0, 12.0),
    )


def simulate_hands(
    people: int = 6, seed: int = 0, rounds: int = 3, first: int = 1, tracker: TrackerSpec = TrackerSpec(),
    protocol: str = "test",
) -> list[HandFrame]:
    """Frames of persons ``first`` .. ``first + people - 1``, one session after the other on one service clock;
    session ``k`` of the file carries ``session = k``. ``protocol="test"``: one session per person in which each
    gesture occurs ``rounds`` times; ``protocol="training"``: the :data:`~spotfree.hand.vocabulary.TRAINING_TASKS`
    sessions of every person in that order (see :func:`training_sequence`). The same arguments give the same
    frames."""
    if people < 1 or rounds < 1 or first < 1:
        raise InputError(f"people ({people}), rounds ({rounds}) and first ({first}) must be at least 1")
    if protocol not in PROTOCOLS:
        raise InputError(f"protocol {protocol!r}: use one of {', '.join(PROTOCOLS)}")
    frames: list[HandFrame] = []
    clock = _rng(seed, 0, "clock").uniform(20.0, 600.0)
    for number in range(first, first + people):
        person = draw_person(seed, number)
        pause = _rng(seed, number, "clock")
        if protocol == "test":
            plan = _rng(seed, number, "plan")
            plans = [(_test_sequence(plan, rounds), plan, ())]
        else:
            plans = [(training_sequence(task, rounds), _rng(seed, number, "plan", k + 1), (k + 1,))
                     for k, task in enumerate(TRAINING_TASKS)]
        for sequence, plan, extra in plans:
            first_id = frames[-1].id + 1 if frames else 0
            session = frames[-1].session + 1 if frames else 1
            session_frames = _session(person, seed, sequence, plan, extra, clock, session, first_id, tracker)
            frames.extend(session_frames)
            clock = session_frames[-1].time + pause.uniform(3.0, 8.0)
    return frames


def training_sequence(task: str, rounds: int = 3) -> list[str]:
    """Postures of one training session, in order (every session starts in ``straight``):

    * ``hold``: ``straight`` only, held 10-14 s (no gesture);
    * ``out-X``: ``straight``, then ``X`` held 4-6 s to the end (the one gesture ``straight-to-X``);
    * ``round-X``: ``rounds`` times ``X`` and back to ``straight`` (both gestures of ``X``).
    """
    kind, _, posture = task.partition("-")
    if task not in TRAINING_TASKS:
        raise InputError(f"training task {task!r}: use one of {', '.join(TRAINING_TASKS)}")
    if kind == "hold":
        return ["straight"]
    if kind == "out":
        return ["straight", posture]
    return ["straight"] + [posture, "straight"] * rounds


# ---------------------------------------------------------------- one session


@dataclass(frozen=True)
class _Segment:
    start: float
    end: float
    state: str
    label: str
    a: Pose
    b: Pose


def _test_sequence(rng: np.random.Generator, rounds: int) -> list[str]:
    """The test protocol: ``rounds`` times each non-straight posture in random order, each from and back to
    ``straight``."""
    order = [str(p) for _ in range(rounds) for p in rng.permutation(POSTURES[1:])]
    sequence = ["straight"]
    for posture in order:
        sequence += [posture, "straight"]
    return sequence


def _plan(person: Person, rng: np.random.Generator, sequence: list[str]) -> list[_Segment]:
    """Holds of the postures of ``sequence`` and the movements between them, from t = 0. The first hold lasts
    2-3 s (the calibration), or 10-14 s when it is the only one; the last hold of a two-posture session 4-6 s;
    any other 0.6-1.5 times the person's mean."""
    segments: list[_Segment] = []
    t = 0.0
    previous = None
    for k, name in enumerate(sequence):
        pose = _vary(person.poses[name], rng)
        if previous is not None:
            angle = (previous[1].rotation.inv() * pose.rotation).magnitude()
            duration = person.move_time * rng.uniform(0.85, 1.2) * (0.7 + 0.6 * angle / np.pi)
            label = f"{previous[0]}-to-{name}"
            segments.append(_Segment(t, t + duration, "gesture", label, previous[1], pose))
            t += duration
        if k == 0:
            hold = 2.0 + rng.uniform(0.0, 1.0) if len(sequence) > 1 else rng.uniform(10.0, 14.0)
        elif len(sequence) == 2:
            hold = rng.uniform(4.0, 6.0)
        else:
            hold = person.hold_time * rng.uniform(0.6, 1.5)
        segments.append(_Segment(t, t + hold, "posture", name, pose, pose))
        t += hold
        previous = (name, pose)
    return segments


def _vary(pose: Pose, rng: np.random.Generator) -> Pose:
    """One execution of a posture: a few mm and degrees from the person's habit."""
    return Pose(
        pose.position + rng.normal(0.0, 4e-3, 3),
        Rotation.from_rotvec(rng.normal(0.0, np.deg2rad(3.0), 3)) * pose.rotation,
        np.clip(pose.curl + rng.normal(0.0, 0.02, 5), 0.0, 1.0),
    )


def _session(
    person: Person, seed: int, sequence: list[str], plan: np.random.Generator, extra: tuple[int, ...],
    clock: float, session: int, first_id: int, tracker: TrackerSpec,
) -> list[HandFrame]:
    """The frames of one person's session of the postures ``sequence`` (holds and movements drawn from ``plan``),
    starting at ``clock`` s on the service clock; ``extra`` numbers the session's random streams among the
    person's (empty: the test session)."""
    segments = _plan(person, plan, sequence)
    motion, noise = _rng(seed, person.number, "motion", *extra), _rng(seed, person.number, "tracker", *extra)
    t = _frame_times(segments[-1].end, noise, tracker)
    which = np.clip(np.searchsorted([s.end for s in segments], t, side="right"), 0, len(segments) - 1)
    position = np.empty((len(t), 3))
    rotations = np.empty((len(t), 4))
    curl = np.empty((len(t), 5))
    for k, seg in enumerate(segments):
        rows = np.flatnonzero(which == k)
        if len(rows):
            position[rows], rotations[rows], curl[rows] = _trajectory(seg, t[rows], person)
    rotation = Rotation.from_rotvec(_sway(t, person.sway_angle, motion)) * Rotation.from_quat(rotations)
    position += person.neutral + _sway(t, person.sway, motion) + _tremor(t, person, motion)
    velocity = np.gradient(position, t, axis=0)
    measured = _measure(t, position, velocity, rotation, curl, person, noise, tracker)
    sent = noise.random(len(t)) >= tracker.drop
    lost = _losses(t, noise, tracker)
    moving = np.array([s.state == "gesture" for s in segments])[which]
    start, end = np.array([s.start for s in segments])[which], np.array([s.end for s in segments])[which]
    relative = np.where(moving, pace((t - start) / (end - start), person.skew), 0.0)
    frames = []
    for i in np.flatnonzero(sent):
        seg = segments[which[i]]
        frames.append(HandFrame(
            timestamp=int(round((clock + t[i]) * 1e6)), hands=() if lost[i] else (measured(i),),
            id=first_id + int(i), session=session,
            truth={"state": seg.state, "label": seg.label, "person": person.number,
                   "pace": round(float(relative[i]), 3)},
        ))
    return frames


def _trajectory(seg: _Segment, t: np.ndarray, person: Person) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Palm position (relative to the neutral), orientation quaternions and finger curl along one segment."""
    if seg.state == "posture":
        n = len(t)
        return np.tile(seg.a.position, (n, 1)), np.tile(seg.a.rotation.as_quat(), (n, 1)), np.tile(seg.a.curl, (n, 1))
    u = np.clip((t - seg.start) / (seg.end - seg.start), 0.0, 1.0) ** person.skew
    s = minimum_jerk(u)[:, None]
    position = seg.a.position + (seg.b.position - seg.a.position) * s + person.arc * np.sin(np.pi * s)
    turn = (seg.a.rotation.inv() * seg.b.rotation).as_rotvec()
    rotation = seg.a.rotation * Rotation.from_rotvec(s * turn)
    lo, hi = person.finger_window
    curl = seg.a.curl + (seg.b.curl - seg.a.curl) * minimum_jerk((u - lo) / (hi - lo))[:, None]
    return position, rotation.as_quat(), curl


def _frame_times(duration: float, rng: np.random.Generator, tracker: TrackerSpec) -> np.ndarray:
    """Frame times from 0 to ``duration`` s at the session's rate with jittered intervals."""
    period = 1.0 / rng.uniform(*tracker.frame_rate)
    count = int(duration / period * 1.2) + 10
    steps = period * np.clip(1.0 + tracker.jitter * rng.standard_normal(count), 0.2, None)
    t = np.r_[0.0, np.cumsum(steps)]
    return t[t <= duration]


def _losses(t: np.ndarray, rng: np.random.Generator, tracker: TrackerSpec) -> np.ndarray:
    """True on frames inside a tracking-loss episode (the frame arrives without a hand)."""
    lost = np.zeros(len(t), dtype=bool)
    for start in rng.uniform(t[0], t[-1], rng.poisson(tracker.loss_rate * (t[-1] - t[0]))):
        lost |= (t >= start) & (t < start + rng.uniform(*tracker.loss_duration))
    return lost


def _ou(t: np.ndarray, sigma: float, tau: float, size: int, rng: np.random.Generator) -> np.ndarray:
    """An Ornstein-Uhlenbeck process (stationary std ``sigma``, time constant ``tau`` s) sampled exactly at ``t``."""
    out = np.empty((len(t), size))
    out[0] = rng.normal(0.0, sigma, size)
    decay = np.exp(-np.diff(t) / tau)
    shocks = rng.standard_normal((len(t) - 1, size)) * (sigma * np.sqrt(1.0 - decay**2))[:, None]
    for i in range(1, len(t)):
        out[i] = decay[i - 1] * out[i - 1] + shocks[i - 1]
    return out


def _sway(t: np.ndarray, sigma: float, rng: np.random.Generator, parts: int = 4) -> np.ndarray:
    """Postural sway (n, 3): per axis a sum of ``parts`` sinusoids of random phase at 0.1-1 Hz, std ``sigma``
    (smooth, so that the velocity it adds stays a few mm/s)."""
    frequency = rng.uniform(0.1, 1.0, (parts, 3))
    phase = rng.uniform(0.0, 2 * np.pi, (parts, 3))
    waves = np.sin(2 * np.pi * frequency[None] * t[:, None, None] + phase[None])
    return sigma * np.sqrt(2.0 / parts) * waves.sum(axis=1)


def _tremor(t: np.ndarray, person: Person, rng: np.random.Generator) -> np.ndarray:
    """Physiological tremor: a sinusoid of the person's frequency along a random axis, slowly wandering phase."""
    axis = rng.normal(size=3)
    phase = 2 * np.pi * person.tremor_frequency * t + np.cumsum(rng.normal(0.0, 0.05, len(t)))
    return person.tremor * np.sin(phase)[:, None] * (axis / np.linalg.norm(axis))


def fingertips(position: np.ndarray, rotation: Rotation, curl: np.ndarray, scale: float) -> np.ndarray:
    """Fingertip positions ``(n, 5, 3)`` m in the Leap frame for palm ``position`` (n, 3), hand ``rotation`` and
    ``curl`` (n, 5): each finger is three segments from its base joint, splayed in the palm plane and flexed toward
    the palm side ``n`` by :data:`FLEX` times its curl."""
    splay = SPLAY * (1.0 - 0.6 * curl)
    flex = np.cumsum(FLEX * curl[:, :, None], axis=2)
    in_plane = np.stack([np.sin(splay), np.cos(splay)], axis=-1)[:, :, None, :]
    segments = np.concatenate([np.cos(flex)[..., None] * in_plane, np.sin(flex)[..., None]], axis=-1)
    base = np.concatenate([KNUCKLES, np.zeros((len(KNUCKLES), 1))], axis=1)
    local = scale * (base + np.sum(SEGMENTS[:, :, None] * segments, axis=2))
    matrices = np.broadcast_to(rotation.as_matrix().reshape(-1, 3, 3), (len(position), 3, 3))
    return position[:, None, :] + np.einsum("nij,nfj->nfi", matrices, local)


def _measure(
    t: np.ndarray, position: np.ndarray, velocity: np.ndarray, rotation: Rotation, curl: np.ndarray, person: Person,
    rng: np.random.Generator, tracker: TrackerSpec,
):
    """What the tracker reports: a function from frame index to the measured :class:`Hand`."""
    n = len(t)
    bias = _ou(t, tracker.position_bias, tracker.bias_time, 3, rng)
    seen = Rotation.from_rotvec(rng.normal(0.0, tracker.angle_noise, (n, 3))) * rotation
    matrices = seen.as_matrix()
    direction, normal = matrices[:, :, 1], matrices[:, :, 2]
    palm = position + bias + rng.normal(0.0, tracker.position_noise, (n, 3))
    noisy_curl = np.clip(curl + rng.normal(0.0, tracker.curl_noise, curl.shape), 0.0, 1.0)
    tips = fingertips(position, rotation, curl, person.scale) + bias[:, None, :]
    tips += rng.normal(0.0, tracker.tip_noise, tips.shape)
    gap = np.linalg.norm(tips[:, 0] - tips[:, 1], axis=1)
    pinch = np.clip(1.0 - (gap - 0.015 * person.scale) / (0.06 * person.scale), 0.0, 1.0)
    strength = rng.normal(0.0, tracker.strength_noise, (n, 2))
    grab = np.clip(noisy_curl[:, 1:].mean(axis=1) + strength[:, 0], 0.0, 1.0)
    pinch = np.clip(pinch + strength[:, 1], 0.0, 1.0)
    speed = velocity + rng.normal(0.0, tracker.velocity_noise, (n, 3))
    width = PALM_WIDTH * person.scale + rng.normal(0.0, 0.5e-3, n)
    confidence = np.clip(rng.normal(0.95, 0.03, n), 0.0, 1.0)

    def measured(i: int) -> Hand:
        return Hand(
            palm_position=palm[i], palm_normal=normal[i], direction=direction[i], palm_velocity=speed[i],
            palm_width=float(width[i]), grab=float(grab[i]), pinch=float(pinch[i]),
            extended=noisy_curl[i] < 0.5, tips=tips[i], side="right", confidence=float(confidence[i]),
            id=person.number,
        )

    return measured


def _mm(*values: float) -> np.ndarray:
    return np.array(values) * 1e-3


def _rng(seed: int, number: int, stream: str, *extra: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([seed, number, STREAMS.index(stream), *extra]))
