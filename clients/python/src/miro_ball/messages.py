"""The messages a robot program receives from the fusion server, as typed dataclasses, and
the functions that build them from the JSON on the wire, checking them on the way.

This module needs no network and no Zenoh: it is plain Python, usable on its own (for
example to read states recorded elsewhere).

Conventions, as in the wire protocol: SI units (metres, seconds, m/s), the field frame has
its origin at the centre of the pitch, x along the long side, y to the left of +x.
Positions and velocities are ``(x, y)`` tuples. A *stamp* is an integer number of
nanoseconds since the UNIX epoch; every stamped message also has a ``stamp_s`` property,
the same instant as float seconds (comparable with :func:`time.time`). Times inside a
message (``t_s``) are seconds after that message's stamp.

Checks (each failure raises :class:`~miro_ball.errors.MessageError` with a reason label):

- ``not_json``: not UTF-8 JSON, not an object, a missing field, a value of the wrong type,
  an unknown status or wall name, NaN/Infinity literals. Fields this client does not know
  are ignored, so that a newer server's optional fields do not break it (the version
  still decides: a message of another version is refused);
- ``no_version`` / ``version``: ``version`` missing or not an integer / not 1 (read first);
- ``non_finite``: a number overflows to infinity;
- ``robot_id``: an id that is not 1-64 characters of ``A-Z a-z 0-9 _ -``;
- ``covariance_asymmetric`` / ``covariance_not_pd``: the state's 4x4 covariance, or a
  predicted point's or the stop's 2x2 one, is not symmetric / not positive definite;
- ``outside_pitch``: a position more than ``max_outside_m`` (1 m) outside the pitch;
- ``stamp``: a stamp further than ``max_clock_skew_s`` from this machine's clock (only when
  a skew is given: off by default, since a replayed match carries its recorded times);
- ``out_of_range``: ``existence``, ``wall_restitution`` or an intercept's ``probability`` outside 0..1, a deceleration
  outside 0..100 m/s², a horizon or stop time outside 0..3600 s, a negative time;
- ``bad_path``: a prediction without samples, or whose samples or bounces are not in time
  order (the client's own check: interpolation needs it).
"""

from __future__ import annotations

import bisect
import json
import math
import re
import time
from dataclasses import dataclass, field
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

from .errors import MessageError

#: The wire version this client speaks.
VERSION = 1

#: Robot and server ids: 1 to 64 characters of A-Z, a-z, 0-9, _ and -.
ID_PATTERN = re.compile(r"[A-Za-z0-9_-]{1,64}")

#: Ball statuses, as on the wire.
STATUSES = ("tracking", "coasting", "stopped", "lost")

#: Wall names, as on the wire.
WALLS = ("x_max", "x_min", "y_max", "y_min")

#: Largest accepted distance of a position outside the pitch rectangle (protocol default).
DEFAULT_MAX_OUTSIDE_M = 1.0

_U64_MAX = 2**64 - 1

Vec2 = Tuple[float, float]
Payload = Union[bytes, bytearray, memoryview, str]


def is_valid_id(s: object) -> bool:
    """Whether ``s`` is a valid robot or server id."""
    return isinstance(s, str) and ID_PATTERN.fullmatch(s) is not None


def stamp_to_s(stamp_ns: int) -> float:
    """A stamp (integer nanoseconds since the UNIX epoch) as float seconds."""
    return stamp_ns / 1e9


def s_to_stamp(t_s: float) -> int:
    """Float seconds since the UNIX epoch as a stamp (integer nanoseconds)."""
    return int(round(t_s * 1e9))


# --------------------------------------------------------------------------- the pitch


@dataclass(frozen=True)
class Pitch:
    """The pitch rectangle, centred on the origin (default: the MiRo pitch, 3.9 x 2.6 m)."""

    length_m: float = 3.9
    width_m: float = 2.6

    def distance_outside(self, p: Sequence[float]) -> float:
        """How far ``p`` lies outside the rectangle, metres (0 inside)."""
        dx = max(abs(p[0]) - self.length_m / 2.0, 0.0)
        dy = max(abs(p[1]) - self.width_m / 2.0, 0.0)
        return math.hypot(dx, dy)

    def contains(self, p: Sequence[float], margin_m: float = 0.0) -> bool:
        """Whether ``p`` is inside the rectangle, or within ``margin_m`` of it."""
        return self.distance_outside(p) <= margin_m


#: The MiRo pitch: 3.9 m x 2.6 m.
MIRO_PITCH = Pitch()


# --------------------------------------------------------------------------- messages


@dataclass(frozen=True)
class PathSample:
    """A point on the predicted path."""

    t_s: float  #: seconds after the prediction's stamp
    position_m: Vec2
    velocity_mps: Vec2
    #: 2x2 covariance of the position, row-major, m² (``None`` from a server that sends none)
    covariance_m2: Optional[Tuple[float, float, float, float]] = None


@dataclass(frozen=True)
class Bounce:
    """A predicted wall bounce."""

    t_s: float  #: seconds after the prediction's stamp
    position_m: Vec2  #: the ball's centre when it touches the wall
    wall: str  #: ``x_max``, ``x_min``, ``y_max`` or ``y_min``


@dataclass(frozen=True)
class StopPoint:
    """Where and when the ball comes to rest (possibly beyond the horizon)."""

    t_s: float  #: seconds after the prediction's stamp (0 when at rest)
    position_m: Vec2
    #: 2x2 covariance of the stop point, row-major, m² (``None`` when not sent)
    covariance_m2: Optional[Tuple[float, float, float, float]] = None


@dataclass(frozen=True)
class Prediction:
    """The ball's predicted path from ``stamp`` on, through wall bounces, to where it stops.

    Carried inside every :class:`BallState` and returned by :meth:`BallClient.predict`.
    """

    version: int
    stamp: int  #: ns since the UNIX epoch; every ``t_s`` counts from here
    horizon_s: float
    samples: Tuple[PathSample, ...]  #: in time order, the first at 0, the last at the horizon
    bounces: Tuple[Bounce, ...] = ()
    stop: Optional[StopPoint] = None

    @property
    def stamp_s(self) -> float:
        """``stamp`` as float seconds since the UNIX epoch."""
        return stamp_to_s(self.stamp)

    def _knots(self) -> List[Tuple[float, Vec2]]:
        """The samples, the bounces and a stop within the horizon, in time order: the
        points a straight line may join (a bounce is a corner of the path)."""
        cached = self.__dict__.get("_knots_cache")
        if cached is None:
            pts = [(s.t_s, s.position_m) for s in self.samples]
            pts += [(b.t_s, b.position_m) for b in self.bounces]
            if self.stop is not None and self.stop.t_s <= self.horizon_s:
                pts.append((self.stop.t_s, self.stop.position_m))
            pts.sort(key=lambda k: k[0])
            cached = pts
            object.__setattr__(self, "_knots_cache", cached)
        return cached

    def position_at(self, t_s: float) -> Vec2:
        """The predicted ball centre ``t_s`` seconds after ``stamp``.

        Linear between the path's points; a wall bounce is one of them, so the path turns
        at the wall rather than cutting the corner. Before 0 it is the first sample. From
        the stop time on it is the stop point; beyond the horizon without a stop it is the
        last sample (the path says nothing further: see ``horizon_s``).
        """
        if not math.isfinite(t_s):
            raise ValueError(f"t_s must be a finite number of seconds, not {t_s!r}")
        if self.stop is not None and t_s >= self.stop.t_s:
            return self.stop.position_m
        knots = self._knots()
        times = [k[0] for k in knots]
        if t_s <= times[0]:
            return knots[0][1]
        if t_s >= times[-1]:
            return knots[-1][1]
        i = bisect.bisect_right(times, t_s)
        (t0, p0), (t1, p1) = knots[i - 1], knots[i]
        if t1 <= t0:
            return p1
        a = (t_s - t0) / (t1 - t0)
        return (p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1]))

    def covariance_at(self, t_s: float) -> Optional[Tuple[float, float, float, float]]:
        """The 2x2 covariance (row-major, m²) of the predicted position ``t_s`` seconds after
        ``stamp``: linear between samples (a blend of two covariances is one too), the
        stop's from the stop time on; ``None`` from a server that sends no covariances."""
        if not math.isfinite(t_s):
            raise ValueError(f"t_s must be a finite number of seconds, not {t_s!r}")
        if self.stop is not None and t_s >= self.stop.t_s and self.stop.covariance_m2 is not None:
            return self.stop.covariance_m2
        times = [s.t_s for s in self.samples]
        if t_s <= times[0]:
            return self.samples[0].covariance_m2
        if t_s >= times[-1]:
            return self.samples[-1].covariance_m2
        i = bisect.bisect_right(times, t_s)
        s0, s1 = self.samples[i - 1], self.samples[i]
        if s0.covariance_m2 is None or s1.covariance_m2 is None:
            return None
        a = 0.0 if s1.t_s <= s0.t_s else (t_s - s0.t_s) / (s1.t_s - s0.t_s)
        return tuple(c0 + a * (c1 - c0) for c0, c1 in zip(s0.covariance_m2, s1.covariance_m2))  # type: ignore[return-value]

    def velocity_at(self, t_s: float) -> Vec2:
        """The predicted ball velocity ``t_s`` seconds after ``stamp``: linear between
        samples, except across a bounce (it jumps there) and after the stop (zero)."""
        if not math.isfinite(t_s):
            raise ValueError(f"t_s must be a finite number of seconds, not {t_s!r}")
        if self.stop is not None and t_s >= self.stop.t_s:
            return (0.0, 0.0)
        times = [s.t_s for s in self.samples]
        if t_s <= times[0]:
            return self.samples[0].velocity_mps
        if t_s >= times[-1]:
            return self.samples[-1].velocity_mps
        i = bisect.bisect_right(times, t_s)
        s0, s1 = self.samples[i - 1], self.samples[i]
        for b in self.bounces:
            if s0.t_s < b.t_s < s1.t_s:
                return s0.velocity_mps if t_s < b.t_s else s1.velocity_mps
        if s1.t_s <= s0.t_s:
            return s1.velocity_mps
        a = (t_s - s0.t_s) / (s1.t_s - s0.t_s)
        v0, v1 = s0.velocity_mps, s1.velocity_mps
        return (v0[0] + a * (v1[0] - v0[0]), v0[1] + a * (v1[1] - v0[1]))

    def position_at_time(self, unix_s: float) -> Vec2:
        """The predicted ball centre at ``unix_s`` (float seconds since the UNIX epoch, as
        :func:`time.time` gives)."""
        return self.position_at(unix_s - self.stamp_s)

    def next_bounce(self, after_t_s: float = 0.0) -> Optional[Bounce]:
        """The first bounce after ``after_t_s``, or ``None``."""
        for b in self.bounces:
            if b.t_s > after_t_s:
                return b
        return None


@dataclass(frozen=True)
class MotionModel:
    """The motion-model parameters the server uses, estimated online from the data."""

    rolling_decel_mps2: float
    wall_restitution: float
    decel_samples: int
    restitution_samples: int
    tangential_retention: float = 0.85
    slide_decel_mps2: float = 3.0
    #: Wall bounces the estimate went through, and kicks nobody reported that the server
    #: inferred, since it started (0 in states from servers that do not count them).
    bounces_seen: int = 0
    kicks_inferred: int = 0


@dataclass(frozen=True)
class BallState:
    """The fused estimate of the ball, shared with every robot (``{prefix}/ball/state``).

    ``server_id`` and ``received_s`` are not part of the message: the client fills them in
    with the id of the server that published it (from the sample's attachment) and the
    time it arrived here (:func:`time.time`).
    """

    version: int
    stamp: int  #: ns since the UNIX epoch: the time the estimate refers to
    position_m: Vec2
    velocity_mps: Vec2
    covariance: Tuple[float, ...]  #: 4x4 covariance of (x, y, vx, vy), row-major
    status: str  #: ``tracking``, ``coasting``, ``stopped`` or ``lost``
    last_seen: Optional[int]  #: capture time (ns) of the newest observation used, or None
    contributors: Tuple[str, ...]  #: robots whose observations updated it recently
    model: MotionModel
    prediction: Prediction
    existence: float = 1.0  #: probability, 0..1, that the ball is where the estimate says
    server_id: Optional[str] = field(default=None, compare=False)
    received_s: Optional[float] = field(default=None, compare=False)

    @property
    def stamp_s(self) -> float:
        """``stamp`` as float seconds since the UNIX epoch."""
        return stamp_to_s(self.stamp)

    @property
    def last_seen_s(self) -> Optional[float]:
        """``last_seen`` as float seconds since the UNIX epoch, or ``None``."""
        return None if self.last_seen is None else stamp_to_s(self.last_seen)

    def age_s(self, now_s: Optional[float] = None) -> float:
        """Seconds from the estimate's stamp to ``now_s`` (default: this machine's clock)."""
        return (time.time() if now_s is None else now_s) - self.stamp_s

    @property
    def speed_mps(self) -> float:
        """The ball's speed, m/s."""
        return math.hypot(*self.velocity_mps)

    @property
    def position_std_m(self) -> Vec2:
        """Standard deviations of x and y, metres (square roots of the covariance's
        diagonal)."""
        return (math.sqrt(self.covariance[0]), math.sqrt(self.covariance[5]))

    @property
    def is_lost(self) -> bool:
        """Whether the server has no usable estimate (``status == "lost"``)."""
        return self.status == "lost"

    def position_at_time(self, unix_s: Optional[float] = None) -> Vec2:
        """Where the prediction puts the ball at ``unix_s`` (default: now), which makes up
        for the time the state took to arrive. See :meth:`Prediction.position_at`."""
        return self.prediction.position_at_time(time.time() if unix_s is None else unix_s)


@dataclass(frozen=True)
class Intercept:
    """The earliest point on the ball's predicted path a robot can reach in time (the reply
    to :meth:`BallClient.intercept`)."""

    version: int
    robot_id: str
    stamp: int  #: ns since the UNIX epoch of the estimate it was computed from
    reachable_in_motion: bool  #: False: the robot only meets the ball once it has stopped
    t_s: float  #: seconds after ``stamp`` when robot and ball meet
    point_m: Vec2  #: where they meet
    #: how likely (0..1) the ball is within the robot's reach there, given how sure the path
    #: is (``None`` from a server that does not say)
    probability: Optional[float] = None

    @property
    def stamp_s(self) -> float:
        """``stamp`` as float seconds since the UNIX epoch."""
        return stamp_to_s(self.stamp)

    @property
    def meet_time_s(self) -> float:
        """When robot and ball meet, float seconds since the UNIX epoch."""
        return self.stamp_s + self.t_s

    def time_to_meet_s(self, now_s: Optional[float] = None) -> float:
        """Seconds from ``now_s`` (default: this machine's clock) until they meet."""
        return self.meet_time_s - (time.time() if now_s is None else now_s)


# --------------------------------------------------------------------------- parsing


@dataclass(frozen=True)
class Checks:
    """What the parsers check beyond the message's shape.

    ``pitch``: the pitch positions are checked against (``None``: no position check).
    ``max_outside_m``: how far outside it a position may be. ``max_clock_skew_s``: largest
    accepted distance of a stamp from this machine's clock (``None``, the default: stamps
    are not checked, so a replayed match, which carries its recorded times, is accepted).
    """

    pitch: Optional[Pitch] = MIRO_PITCH
    max_outside_m: float = DEFAULT_MAX_OUTSIDE_M
    max_clock_skew_s: Optional[float] = None


DEFAULT_CHECKS = Checks()


def _reject_constant(name: str) -> Any:
    raise MessageError("not_json", f"{name} is not a JSON number")


def _load(payload: Payload, what: str) -> Dict[str, Any]:
    """JSON text to a dict, with the version checked first."""
    if isinstance(payload, (bytes, bytearray, memoryview)):
        try:
            text = bytes(payload).decode("utf-8")
        except UnicodeDecodeError as e:
            raise MessageError("not_json", f"{what} is not UTF-8: {e}") from None
    elif isinstance(payload, str):
        text = payload
    else:
        raise TypeError(f"payload must be bytes or str, not {type(payload).__name__}")
    try:
        obj = json.loads(text, parse_constant=_reject_constant)
    except MessageError:
        raise
    except (ValueError, RecursionError) as e:
        raise MessageError("not_json", f"{what} is not JSON: {e}") from None
    if not isinstance(obj, dict):
        raise MessageError("not_json", f"{what} is not a JSON object")
    _check_version(obj, what)
    return obj


def _check_version(obj: Dict[str, Any], what: str) -> None:
    v = obj.get("version")
    if "version" not in obj or not _is_int(v):
        raise MessageError("no_version", f"{what} has no integer version")
    if v != VERSION:
        raise MessageError("version", f"{what} has version {v}, this client speaks {VERSION}")


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


class _Reader:
    """Reads one JSON object's fields, rejecting missing ones and ignoring unknown ones."""

    def __init__(self, obj: Any, where: str, required: Iterable[str], optional: Iterable[str] = ()):
        if not isinstance(obj, dict):
            raise MessageError("not_json", f"{where} is not an object")
        req = tuple(required)
        missing = [k for k in req if k not in obj]
        if missing:
            raise MessageError("not_json", f"{where} lacks field(s) {', '.join(missing)}")
        self.obj, self.where = obj, where

    def has(self, k: str) -> bool:
        return self.obj.get(k) is not None

    def num(self, k: str) -> float:
        v = self.obj[k]
        if not _is_num(v):
            raise MessageError("not_json", f"{self.where}.{k} is not a number")
        return float(v)

    def int_(self, k: str, hi: int = _U64_MAX) -> int:
        v = self.obj[k]
        if not _is_int(v) or not 0 <= v <= hi:
            raise MessageError("not_json", f"{self.where}.{k} is not an unsigned integer")
        return v

    def vec(self, k: str, n: int = 2) -> Tuple[float, ...]:
        v = self.obj[k]
        if not isinstance(v, list) or len(v) != n or not all(_is_num(x) for x in v):
            raise MessageError("not_json", f"{self.where}.{k} is not a list of {n} numbers")
        return tuple(float(x) for x in v)

    def str_(self, k: str, choices: Optional[Sequence[str]] = None) -> str:
        v = self.obj[k]
        if not isinstance(v, str):
            raise MessageError("not_json", f"{self.where}.{k} is not a string")
        if choices is not None and v not in choices:
            raise MessageError("not_json", f"{self.where}.{k} is {v!r}, not one of {', '.join(choices)}")
        return v

    def list_(self, k: str) -> list:
        v = self.obj[k]
        if not isinstance(v, list):
            raise MessageError("not_json", f"{self.where}.{k} is not a list")
        return v


def _cov2(r: "_Reader", where: str) -> Optional[Tuple[float, float, float, float]]:
    """An optional 2x2 covariance field, checked symmetric and positive definite."""
    if not r.has("covariance_m2"):
        return None
    v = r.obj["covariance_m2"]
    if not isinstance(v, list) or len(v) != 4 or not all(_is_num(x) for x in v):
        raise MessageError("not_json", f"{where} is not a list of 4 numbers")
    c = tuple(float(x) for x in v)
    if not all(math.isfinite(x) for x in c):
        raise MessageError("non_finite", f"{where} has a non-finite number")
    _check_covariance(c, 2, where)
    return c  # type: ignore[return-value]


def _decode_prediction(obj: Any, where: str) -> Prediction:
    if isinstance(obj, dict):
        _check_version(obj, where)
    r = _Reader(obj, where, ("version", "stamp", "horizon_s", "samples", "bounces"), ("stop",))
    samples = []
    for i, s in enumerate(r.list_("samples")):
        sr = _Reader(s, f"{where}.samples[{i}]", ("t_s", "position_m", "velocity_mps"))
        samples.append(
            PathSample(
                sr.num("t_s"),
                sr.vec("position_m"),
                sr.vec("velocity_mps"),
                _cov2(sr, f"{where}.samples[{i}].covariance_m2"),
            )
        )
    bounces = []
    for i, b in enumerate(r.list_("bounces")):
        br = _Reader(b, f"{where}.bounces[{i}]", ("t_s", "position_m", "wall"))
        bounces.append(Bounce(br.num("t_s"), br.vec("position_m"), br.str_("wall", WALLS)))
    stop = None
    if r.has("stop"):
        st = _Reader(r.obj["stop"], f"{where}.stop", ("t_s", "position_m"))
        stop = StopPoint(st.num("t_s"), st.vec("position_m"), _cov2(st, f"{where}.stop.covariance_m2"))
    return Prediction(
        version=r.obj["version"],
        stamp=r.int_("stamp"),
        horizon_s=r.num("horizon_s"),
        samples=tuple(samples),
        bounces=tuple(bounces),
        stop=stop,
    )


def _decode_state(obj: Dict[str, Any]) -> BallState:
    r = _Reader(
        obj,
        "BallState",
        ("version", "stamp", "position_m", "velocity_mps", "covariance", "status",
         "contributors", "model", "prediction"),
        ("last_seen", "existence"),
    )
    m = _Reader(
        r.obj["model"],
        "BallState.model",
        ("rolling_decel_mps2", "wall_restitution", "decel_samples", "restitution_samples"),
        ("tangential_retention", "slide_decel_mps2", "bounces_seen", "kicks_inferred"),
    )
    model = MotionModel(
        rolling_decel_mps2=m.num("rolling_decel_mps2"),
        wall_restitution=m.num("wall_restitution"),
        decel_samples=m.int_("decel_samples", 2**32 - 1),
        restitution_samples=m.int_("restitution_samples", 2**32 - 1),
        tangential_retention=m.num("tangential_retention") if m.has("tangential_retention") else 0.85,
        slide_decel_mps2=m.num("slide_decel_mps2") if m.has("slide_decel_mps2") else 3.0,
        bounces_seen=m.int_("bounces_seen", 2**32 - 1) if m.has("bounces_seen") else 0,
        kicks_inferred=m.int_("kicks_inferred", 2**32 - 1) if m.has("kicks_inferred") else 0,
    )
    contributors = r.list_("contributors")
    if not all(isinstance(c, str) for c in contributors):
        raise MessageError("not_json", "BallState.contributors holds a value that is not a string")
    return BallState(
        version=r.obj["version"],
        stamp=r.int_("stamp"),
        position_m=r.vec("position_m"),
        velocity_mps=r.vec("velocity_mps"),
        covariance=r.vec("covariance", 16),
        status=r.str_("status", STATUSES),
        last_seen=r.int_("last_seen") if r.has("last_seen") else None,
        contributors=tuple(contributors),
        model=model,
        prediction=_decode_prediction(r.obj["prediction"], "BallState.prediction"),
        existence=r.num("existence") if r.has("existence") else 1.0,
    )


def _decode_intercept(obj: Dict[str, Any]) -> Intercept:
    r = _Reader(obj, "Intercept", ("version", "robot_id", "stamp", "reachable_in_motion", "t_s", "point_m"))
    reach = r.obj["reachable_in_motion"]
    if not isinstance(reach, bool):
        raise MessageError("not_json", "Intercept.reachable_in_motion is not a boolean")
    return Intercept(
        version=r.obj["version"],
        robot_id=r.str_("robot_id"),
        stamp=r.int_("stamp"),
        reachable_in_motion=reach,
        t_s=r.num("t_s"),
        point_m=r.vec("point_m"),
        probability=r.num("probability") if r.has("probability") else None,
    )


# --------------------------------------------------------------------------- semantic checks


def _finite(where: str, *values: float) -> None:
    for v in values:
        if not math.isfinite(v):
            raise MessageError("non_finite", f"{where} holds a number that is not finite")


def _prediction_numbers(p: Prediction) -> List[float]:
    nums = [p.horizon_s]
    for s in p.samples:
        nums += [s.t_s, *s.position_m, *s.velocity_mps]
    for b in p.bounces:
        nums += [b.t_s, *b.position_m]
    if p.stop is not None:
        nums += [p.stop.t_s, *p.stop.position_m]
    return nums


def _check_covariance(c: Sequence[float], n: int, where: str) -> None:
    scale = max(abs(x) for x in c)
    for i in range(n):
        for j in range(i + 1, n):
            if abs(c[i * n + j] - c[j * n + i]) > 1e-9 * scale:
                raise MessageError("covariance_asymmetric", f"{where} is not symmetric")
    # Cholesky factorisation: exists exactly when the matrix is positive definite.
    low = [[0.0] * n for _ in range(n)]
    for j in range(n):
        d = c[j * n + j] - sum(low[j][k] ** 2 for k in range(j))
        if not d > 0.0 or not math.isfinite(d):
            raise MessageError("covariance_not_pd", f"{where} is not positive definite")
        low[j][j] = math.sqrt(d)
        for i in range(j + 1, n):
            low[i][j] = (c[i * n + j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[j][j]


def _check_positions(where: str, points: Iterable[Vec2], checks: Checks) -> None:
    if checks.pitch is None:
        return
    for p in points:
        d = checks.pitch.distance_outside(p)
        if d > checks.max_outside_m:
            raise MessageError(
                "outside_pitch",
                f"{where} position ({p[0]:+.2f}, {p[1]:+.2f}) m is {d:.2f} m outside the "
                f"{checks.pitch.length_m} x {checks.pitch.width_m} m pitch",
            )


def _check_stamp(where: str, stamp: int, checks: Checks, now_s: Optional[float]) -> None:
    if checks.max_clock_skew_s is None:
        return
    now = time.time() if now_s is None else now_s
    skew = stamp_to_s(stamp) - now
    if abs(skew) > checks.max_clock_skew_s:
        raise MessageError(
            "stamp",
            f"{where} stamp is {skew:+.1f} s from this machine's clock "
            f"(more than {checks.max_clock_skew_s} s): are the clocks synchronised?",
        )


def _check_range(where: str, value: float, lo: float, hi: float) -> None:
    if not lo <= value <= hi:
        raise MessageError("out_of_range", f"{where} = {value} is outside {lo}..{hi}")


def _check_path(p: Prediction, where: str) -> None:
    if not p.samples:
        raise MessageError("bad_path", f"{where} has no samples")
    prev = -math.inf
    for s in p.samples:
        if s.t_s < prev:
            raise MessageError("bad_path", f"{where}.samples are not in time order")
        prev = s.t_s
    prev = -math.inf
    for b in p.bounces:
        if b.t_s < prev:
            raise MessageError("bad_path", f"{where}.bounces are not in time order")
        prev = b.t_s


def _validate_prediction(p: Prediction, where: str, checks: Checks, now_s: Optional[float]) -> None:
    # In the protocol's order: non_finite, outside_pitch, stamp, out_of_range; then the path.
    _finite(where, *_prediction_numbers(p))
    _check_positions(f"{where} sample", (s.position_m for s in p.samples), checks)
    _check_stamp(where, p.stamp, checks, now_s)
    _check_range(f"{where}.horizon_s", p.horizon_s, 0.0, 3600.0)
    if p.stop is not None:
        _check_range(f"{where}.stop.t_s", p.stop.t_s, 0.0, 3600.0)
    for s in p.samples:
        _check_range(f"{where} sample t_s", s.t_s, 0.0, 3600.0)
    for b in p.bounces:
        _check_range(f"{where} bounce t_s", b.t_s, 0.0, 3600.0)
    _check_path(p, where)


def _validate_state(s: BallState, checks: Checks, now_s: Optional[float]) -> None:
    m = s.model
    _finite(
        "BallState",
        *s.position_m, *s.velocity_mps, *s.covariance, s.existence,
        m.rolling_decel_mps2, m.wall_restitution, m.tangential_retention, m.slide_decel_mps2,
        *_prediction_numbers(s.prediction),
    )
    for c in s.contributors:
        if not is_valid_id(c):
            raise MessageError("robot_id", f"BallState.contributors holds {c!r}, not a valid robot id")
    _check_covariance(s.covariance, 4, "BallState.covariance")
    _check_positions("BallState", [s.position_m], checks)
    _check_positions("BallState.prediction sample", (p.position_m for p in s.prediction.samples), checks)
    _check_stamp("BallState", s.stamp, checks, now_s)
    _check_stamp("BallState.prediction", s.prediction.stamp, checks, now_s)
    _check_range("BallState.existence", s.existence, 0.0, 1.0)
    _check_range("BallState.model.wall_restitution", m.wall_restitution, 0.0, 1.0)
    _check_range("BallState.model.rolling_decel_mps2", m.rolling_decel_mps2, 0.0, 100.0)
    _validate_prediction(s.prediction, "BallState.prediction", checks, now_s)


def _validate_intercept(i: Intercept) -> None:
    _finite("Intercept", i.t_s, *i.point_m)
    if not is_valid_id(i.robot_id):
        raise MessageError("robot_id", f"Intercept.robot_id {i.robot_id!r} is not a valid robot id")
    _check_range("Intercept.t_s", i.t_s, 0.0, 3600.0)
    if i.probability is not None:
        _finite("Intercept.probability", i.probability)
        _check_range("Intercept.probability", i.probability, 0.0, 1.0)


# --------------------------------------------------------------------------- public parsers


def parse_ball_state(
    payload: Payload,
    checks: Checks = DEFAULT_CHECKS,
    *,
    now_s: Optional[float] = None,
    server_id: Optional[str] = None,
    received_s: Optional[float] = None,
) -> BallState:
    """A :class:`BallState` from its JSON, checked; raises
    :class:`~miro_ball.errors.MessageError` (with ``reason``) when it is not valid."""
    state = _decode_state(_load(payload, "BallState"))
    _validate_state(state, checks, now_s)
    if server_id is not None or received_s is not None:
        object.__setattr__(state, "server_id", server_id)
        object.__setattr__(state, "received_s", received_s)
    return state


def parse_prediction(payload: Payload, checks: Checks = DEFAULT_CHECKS, *, now_s: Optional[float] = None) -> Prediction:
    """A :class:`Prediction` from its JSON, checked; raises
    :class:`~miro_ball.errors.MessageError` when it is not valid."""
    p = _decode_prediction(_load(payload, "Prediction"), "Prediction")
    _validate_prediction(p, "Prediction", checks, now_s)
    return p


def parse_intercept(payload: Payload) -> Intercept:
    """An :class:`Intercept` from its JSON, checked; raises
    :class:`~miro_ball.errors.MessageError` when it is not valid."""
    i = _decode_intercept(_load(payload, "Intercept"))
    _validate_intercept(i)
    return i
