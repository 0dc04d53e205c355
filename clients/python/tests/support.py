"""What the tests share: the wire protocol's example messages, builders of variants, and an
offline client (no network) to feed payloads to."""

import copy
import json
import os
import unittest

from miro_ball import BallClient
from miro_ball.messages import DEFAULT_CHECKS

# The examples of the wire protocol (docs/protocol.md), field for field.
BALL_STATE = {
    "version": 1,
    "stamp": 1700000000000000000,
    "position_m": [1.2, 0.4],
    "velocity_mps": [1.1, 0.3],
    "covariance": [
        0.0009, 0.0001, 0.0005, 0.0,
        0.0001, 0.0009, 0.0, 0.0005,
        0.0005, 0.0, 0.01, 0.001,
        0.0, 0.0005, 0.001, 0.01,
    ],
    "status": "tracking",
    "last_seen": 1699999999965000000,
    "contributors": ["miro1", "miro3"],
    "existence": 0.97,
    "model": {
        "rolling_decel_mps2": 0.45,
        "wall_restitution": 0.55,
        "decel_samples": 12,
        "restitution_samples": 4,
        "tangential_retention": 0.9,
        "slide_decel_mps2": 2.8,
        "bounces_seen": 9,
        "kicks_inferred": 2,
    },
    "prediction": {
        "version": 1,
        "stamp": 1700000000000000000,
        "horizon_s": 2.0,
        "samples": [
            {"t_s": 0.0, "position_m": [1.2, 0.4], "velocity_mps": [1.1, 0.3],
             "covariance_m2": [0.0004, 0.0001, 0.0001, 0.0003]},
            {"t_s": 1.0, "position_m": [1.83, 0.64], "velocity_mps": [-0.35, 0.2],
             "covariance_m2": [0.004, 0.001, 0.001, 0.002]},
            {"t_s": 2.0, "position_m": [1.62, 0.76], "velocity_mps": [-0.08, 0.04],
             "covariance_m2": [0.012, 0.002, 0.002, 0.006]},
        ],
        "bounces": [{"t_s": 0.62, "position_m": [1.91, 0.58], "wall": "x_max"}],
        "stop": {"t_s": 2.4, "position_m": [1.6, 0.77],
                 "covariance_m2": [0.015, 0.002, 0.002, 0.007]},
    },
}

PREDICTION = copy.deepcopy(BALL_STATE["prediction"])

INTERCEPT = {
    "version": 1,
    "robot_id": "miro2",
    "stamp": 1700000000000000000,
    "reachable_in_motion": True,
    "t_s": 1.35,
    "point_m": [1.78, 0.69],
    "probability": 0.82,
}


def state(**changes):
    """The example BallState with top-level fields replaced (a value of ``DELETE`` removes
    the field)."""
    s = copy.deepcopy(BALL_STATE)
    for k, v in changes.items():
        if v is DELETE:
            s.pop(k, None)
        else:
            s[k] = v
    return s


DELETE = object()


def dumps(obj):
    return json.dumps(obj).encode("utf-8")


def offline_client(checks=DEFAULT_CHECKS, robot_id=None):
    """A BallClient with no session, to feed payloads to (``feed_state``)."""
    c = BallClient.__new__(BallClient)
    c._init(("tcp/127.0.0.1:7447",), "rf", False, robot_id, 1.0, checks)
    return c


def env(name):
    """An environment variable the network tests need; skips the test when it is unset."""
    v = os.environ.get(name)
    if not v:
        raise unittest.SkipTest(f"{name} is not set (run clients/python/run-tests.sh)")
    return v
