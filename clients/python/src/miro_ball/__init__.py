"""miro_ball: the team's shared ball, for a MiRo robot's own Python program.

The team's fusion server combines every robot's sightings into one ball estimate and
publishes it over Zenoh. This package connects to it::

    from miro_ball import BallClient

    with BallClient.connect(["tcp/127.0.0.1:7447"]) as ball:
        state = ball.wait_state(timeout_s=2.0)
        print(state.status, state.position_m, state.velocity_mps)
        where = ball.predict(1.0).position_at(1.0)      # the ball in one second
        meet = ball.intercept("miro1")                   # where miro1 can meet it

On a secured network give the robot's own key folder and a ``tls/`` endpoint::

    BallClient.connect(["tls/pitch-server.local:7447"], keys_dir="robot-miro1")

See the README beside this package for the whole API.
"""

from .client import BallClient, ClientStats
from .errors import (
    BallClientError,
    ClientClosedError,
    ConfigError,
    MessageError,
    NoReplyError,
    NoServerError,
    NoStateError,
    QueryError,
)
from .messages import (
    MIRO_PITCH,
    VERSION,
    BallState,
    Bounce,
    Checks,
    Intercept,
    MotionModel,
    PathSample,
    Pitch,
    Prediction,
    StopPoint,
    parse_ball_state,
    parse_intercept,
    parse_prediction,
    s_to_stamp,
    stamp_to_s,
)

__version__ = "0.1.0"

__all__ = [
    "BallClient",
    "ClientStats",
    "BallClientError",
    "ClientClosedError",
    "ConfigError",
    "MessageError",
    "NoReplyError",
    "NoServerError",
    "NoStateError",
    "QueryError",
    "MIRO_PITCH",
    "VERSION",
    "BallState",
    "Bounce",
    "Checks",
    "Intercept",
    "MotionModel",
    "PathSample",
    "Pitch",
    "Prediction",
    "StopPoint",
    "parse_ball_state",
    "parse_intercept",
    "parse_prediction",
    "s_to_stamp",
    "stamp_to_s",
]
