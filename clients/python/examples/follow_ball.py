#!/usr/bin/env python3
"""A minimal MiRo behaviour loop on the team's shared ball.

Every half second it prints where the ball is (and where it will be when this robot gets
there), and where this robot can meet it. A real behaviour would steer the robot towards
``meet.point_m`` instead of printing it.

Open lab network, server on this machine:

    python3 follow_ball.py --robot miro1 --connect tcp/127.0.0.1:7447

Secured network, with this robot's own key folder from `fusion-server keys`:

    python3 follow_ball.py --keys robot-miro1 --connect tls/pitch-server.local:7447

Ctrl-C stops it (or --for-s SECONDS).
"""

import argparse
import sys
import time

from miro_ball import BallClient, BallClientError, NoStateError, QueryError


def describe_ball(state):
    x, y = state.position_m
    line = (f"ball {state.status:8s} at ({x:+.2f}, {y:+.2f}) m, {state.speed_mps:.2f} m/s, "
            f"{state.age_s() * 1000:.0f} ms old")
    stop = state.prediction.stop
    if stop is not None and stop.t_s > 0:
        line += f", stops at ({stop.position_m[0]:+.2f}, {stop.position_m[1]:+.2f}) in {stop.t_s:.1f} s"
    return line


def describe_meet(robot, meet):
    x, y = meet.point_m
    how = "rolling" if meet.reachable_in_motion else "at rest"
    return f"{robot} meets it at ({x:+.2f}, {y:+.2f}) m in {meet.time_to_meet_s():.2f} s ({how})"


def main():
    ap = argparse.ArgumentParser(description="Follow the team's shared ball.")
    ap.add_argument("--connect", action="append", metavar="ENDPOINT",
                    help="Zenoh endpoint of the fusion server (repeatable; default tcp/127.0.0.1:7447)")
    ap.add_argument("--keys", metavar="DIR", help="this robot's key folder (robot-ID) on a secured network")
    ap.add_argument("--robot", metavar="ID", help="this robot's id (default: from the key folder's name)")
    ap.add_argument("--prefix", default="rf", help="key prefix (default rf)")
    ap.add_argument("--period-s", type=float, default=0.5, help="seconds between lines (default 0.5)")
    ap.add_argument("--for-s", type=float, help="stop after this many seconds (default: until Ctrl-C)")
    args = ap.parse_args()

    try:
        client = BallClient.connect(
            args.connect or ["tcp/127.0.0.1:7447"],
            keys_dir=args.keys,
            prefix=args.prefix,
            robot_id=args.robot,
        )
    except BallClientError as e:
        print(f"follow_ball: {e}", file=sys.stderr)
        return 2

    robot = client.robot_id
    print(f"connected to fusion server(s) {', '.join(client.servers())} as robot {robot or '(none)'}", flush=True)
    end = None if args.for_s is None else time.monotonic() + args.for_s
    try:
        with client:
            while end is None or time.monotonic() < end:
                tick = time.monotonic()
                try:
                    state = client.wait_state(timeout_s=1.0)
                except NoStateError as e:
                    print(f"no ball yet: {e}", flush=True)
                    continue
                line = describe_ball(state)
                if robot is not None and not state.is_lost:
                    try:
                        line += " | " + describe_meet(robot, client.intercept(robot))
                    except QueryError as e:
                        line += f" | no intercept: {e.server_message}"
                print(line, flush=True)
                time.sleep(max(0.0, args.period_s - (time.monotonic() - tick)))
    except KeyboardInterrupt:
        pass
    except BallClientError as e:
        print(f"follow_ball: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
