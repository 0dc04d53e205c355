"""The client against real processes: a fusion server with simulated robots, on an open and
on a secured network, and an endpoint where nothing listens.

run-tests.sh starts them and passes where they are in environment variables:

- ``MIRO_BALL_OPEN_ENDPOINT``, ``MIRO_BALL_OPEN_SERVER_ID``, ``MIRO_BALL_OPEN_ROBOTS``: the
  open network's server endpoint, its id, and the simulated robots (comma-separated);
- ``MIRO_BALL_TLS_ENDPOINT``, ``MIRO_BALL_KEYS`` (the network's key folder, with a
  ``robot-{id}`` folder per robot), ``MIRO_BALL_TLS_ROBOTS`` (the roster, all simulated),
  ``MIRO_BALL_INTRUDER`` (a robot with a key folder but not on the roster) and
  ``MIRO_BALL_OTHER_KEYS`` (a robot folder from another authority);
- ``MIRO_BALL_ROUTER_ENDPOINT``: a router (with the access-control list) in front of a
  secured server that has no robots;
- ``MIRO_BALL_DEAD_ENDPOINT``: a loopback endpoint where nothing listens;
- ``FUSION_SERVER``: the server program, for a test that starts and stops its own.

A test whose variables are unset is skipped (run_all.py counts skips as failures when
``MIRO_BALL_REQUIRE_ALL=1``).
"""

import socket
import subprocess
import sys
import threading
import time
import unittest
from pathlib import Path

import zenoh

from miro_ball import (
    MIRO_PITCH,
    BallClient,
    BallState,
    ClientClosedError,
    Intercept,
    NoReplyError,
    NoServerError,
    NoStateError,
    Prediction,
    QueryError,
)

from support import BALL_STATE, dumps, env, state

FIRST_STATE_S = 15.0  # the robots need a moment to see the ball after they start
EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "follow_ball.py"


def assert_in_pitch(test, p, what):
    """Inside the 3.9 x 2.6 m pitch centred at 0."""
    test.assertLessEqual(abs(p[0]), MIRO_PITCH.length_m / 2, f"{what} x = {p[0]}")
    test.assertLessEqual(abs(p[1]), MIRO_PITCH.width_m / 2, f"{what} y = {p[1]}")


def assert_good_prediction(test, p, horizon_s=None):
    test.assertIsInstance(p, Prediction)
    times = [s.t_s for s in p.samples]
    test.assertGreaterEqual(len(times), 2)
    test.assertEqual(times[0], 0.0)
    test.assertTrue(all(a < b for a, b in zip(times, times[1:])), f"samples out of time order: {times}")
    test.assertAlmostEqual(times[-1], p.horizon_s, places=6)
    if horizon_s is not None:
        test.assertAlmostEqual(p.horizon_s, horizon_s, places=9)
    bt = [b.t_s for b in p.bounces]
    test.assertEqual(bt, sorted(bt))
    for s in p.samples:
        assert_in_pitch(test, s.position_m, f"sample at {s.t_s:.2f} s")
    # The interpolated path goes through the samples.
    for s in p.samples:
        if p.stop is None or s.t_s < p.stop.t_s:
            x, y = p.position_at(s.t_s)
            test.assertAlmostEqual(x, s.position_m[0], places=9)
            test.assertAlmostEqual(y, s.position_m[1], places=9)


def fresh(test, stamp_s, what, within_s=10.0):
    test.assertLess(abs(time.time() - stamp_s), within_s, f"{what} stamp is not near this machine's clock")


class OpenNetwork(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.endpoint = env("MIRO_BALL_OPEN_ENDPOINT")
        cls.server_id = env("MIRO_BALL_OPEN_SERVER_ID")
        cls.robots = env("MIRO_BALL_OPEN_ROBOTS").split(",")
        t0 = time.monotonic()
        cls.client = BallClient.connect([cls.endpoint], server_timeout_s=5.0)
        cls.connect_s = time.monotonic() - t0
        cls.first = cls.client.wait_state(FIRST_STATE_S)

    @classmethod
    def tearDownClass(cls):
        cls.client.close()

    def test_connects_quickly_and_sees_the_server(self):
        self.assertLess(self.connect_s, 2.0)
        self.assertIn(self.server_id, self.client.servers())
        self.assertFalse(self.client.secured)

    def test_states_arrive_inside_the_pitch(self):
        got = []
        cb = self.client.on_state(got.append)
        try:
            time.sleep(1.0)
        finally:
            self.client.remove_callback(cb)
        # The server publishes 30 states a second.
        self.assertGreater(len(got), 10)
        for s in got:
            self.assertIsInstance(s, BallState)
            assert_in_pitch(self, s.position_m, "ball")
            self.assertIn(s.status, ("tracking", "coasting", "stopped", "lost"))
            self.assertEqual(s.server_id, self.server_id)
            fresh(self, s.stamp_s, "state")
            self.assertTrue(set(s.contributors) <= set(self.robots), s.contributors)
        stamps = [s.stamp for s in got]
        self.assertEqual(stamps, sorted(stamps))
        latest = self.client.latest_state()
        self.assertIsNotNone(latest)
        self.assertGreaterEqual(latest.stamp, got[-1].stamp)
        stats = self.client.stats()
        self.assertEqual(stats.rejected, {}, stats.last_rejection)

    def test_each_state_carries_a_good_prediction(self):
        s = self.client.wait_state(2.0)
        assert_good_prediction(self, s.prediction)
        self.assertEqual(s.prediction.stamp, s.stamp)
        self.assertEqual(s.prediction.samples[0].position_m, s.position_m)
        # Where the ball is now, from the prediction: on the pitch, near the state.
        x, y = s.position_at_time()
        assert_in_pitch(self, (x, y), "ball now")

    def test_wait_state_waits_for_a_newer_one(self):
        a = self.client.wait_state(2.0)
        b = self.client.wait_state(2.0)
        self.assertGreater(b.stamp, a.stamp)
        seen = []
        for s in self.client.states(timeout_s=2.0):
            seen.append(s)
            if len(seen) == 3:
                break
        self.assertEqual(len(seen), 3)

    def test_predict(self):
        p = self.client.predict(1.5)
        assert_good_prediction(self, p, horizon_s=1.5)
        fresh(self, p.stamp_s, "prediction")
        p0 = self.client.predict(0)
        self.assertEqual(p0.horizon_s, 0.0)

    def test_predict_refused_is_a_clear_error(self):
        with self.assertRaises(QueryError) as cm:
            self.client.predict(1e6)
        self.assertIn("t=", cm.exception.server_message)
        self.assertIn("rf/ball/predict?t=", str(cm.exception))
        with self.assertRaises(ValueError):
            self.client.predict(-1.0)

    def test_intercept_is_for_the_asked_robot(self):
        for robot in self.robots:
            for speed in (None, 1.0):
                i = self.client.intercept(robot, speed_mps=speed)
                self.assertIsInstance(i, Intercept)
                self.assertEqual(i.robot_id, robot)
                self.assertGreaterEqual(i.t_s, 0.0)
                assert_in_pitch(self, i.point_m, f"{robot}'s intercept")
                fresh(self, i.stamp_s, "intercept")

    def test_unknown_robot_is_a_clear_error(self):
        t0 = time.monotonic()
        with self.assertRaises(QueryError) as cm:
            self.client.intercept("nobody")
        self.assertLess(time.monotonic() - t0, 1.0)
        self.assertIn('"nobody"', cm.exception.server_message)
        self.assertIn("robot=nobody", str(cm.exception))
        with self.assertRaises(ValueError):
            self.client.intercept("no body")
        with self.assertRaises(ValueError):
            self.client.intercept()  # an open network's client knows no robot of its own
        with self.assertRaises(ValueError):
            self.client.intercept(self.robots[0], speed_mps=0.0)

    def test_a_raising_callback_does_not_stop_the_states(self):
        def broken(_):
            raise RuntimeError("bug in a behaviour")

        before = self.client.stats().callback_errors
        with self.assertLogs("miro_ball", "ERROR"):
            self.client.on_state(broken)
            try:
                self.client.wait_state(2.0)
                self.client.wait_state(2.0)
            finally:
                self.client.remove_callback(broken)
        self.assertGreaterEqual(self.client.stats().callback_errors - before, 2)
        self.client.wait_state(2.0)

    def test_the_example_runs(self):
        out = subprocess.run(
            [sys.executable, str(EXAMPLE), "--connect", self.endpoint, "--robot", self.robots[0],
             "--for-s", "1.6", "--period-s", "0.5"],
            capture_output=True, text=True, timeout=30,
        )
        self.assertEqual(out.returncode, 0, out.stderr)
        lines = out.stdout.splitlines()
        self.assertIn(f"connected to fusion server(s) {self.server_id}", lines[0])
        balls = [ln for ln in lines if ln.startswith("ball ")]
        self.assertGreaterEqual(len(balls), 2, out.stdout)
        self.assertTrue(any(f"{self.robots[0]} meets it at" in ln for ln in balls), out.stdout)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class MalformedStates(unittest.TestCase):
    """A peer that publishes junk on the ball's key: the client skips it, counts it, and
    goes on with the server's states."""

    def test_junk_is_counted_and_skipped(self):
        endpoint = env("MIRO_BALL_OPEN_ENDPOINT")
        port = free_port()
        conf = zenoh.Config()
        for k, v in [("mode", '"peer"'), ("listen/endpoints", f'["tcp/127.0.0.1:{port}"]'),
                     ("connect/endpoints", "[]"), ("scouting/multicast/enabled", "false"),
                     ("scouting/gossip/enabled", "false"), ("adminspace/enabled", "false")]:
            conf.insert_json5(k, v)
        junk_peer = zenoh.open(conf)
        try:
            with BallClient.connect([endpoint, f"tcp/127.0.0.1:{port}"], server_timeout_s=5.0) as client:
                client.wait_state(FIRST_STATE_S)
                bad_cov = list(BALL_STATE["covariance"])
                bad_cov[0] = -1.0
                junk = {
                    "not_json": b"{this is not json",
                    "version": dumps(state(version=2)),
                    "covariance_not_pd": dumps(state(covariance=bad_cov)),
                    "outside_pitch": dumps(state(position_m=[9.0, 0.0])),
                }
                with self.assertLogs("miro_ball", "WARNING"):
                    deadline = time.monotonic() + 5.0
                    # Until the junk peer has learnt of the client's subscription.
                    while time.monotonic() < deadline and set(client.stats().rejected) != set(junk):
                        for payload in junk.values():
                            junk_peer.put("rf/ball/state", payload)
                        time.sleep(0.05)
                stats = client.stats()
                self.assertEqual(set(stats.rejected), set(junk), stats)
                self.assertEqual(stats.states_received, stats.states_accepted + stats.states_rejected)
                # The server's states still arrive, and the latest is a real one.
                s = client.wait_state(2.0)
                assert_in_pitch(self, s.position_m, "ball")
                self.assertEqual(s.server_id, env("MIRO_BALL_OPEN_SERVER_ID"))
                self.assertNotEqual(client.latest_state().position_m, (9.0, 0.0))
        finally:
            junk_peer.close()


class SecuredNetwork(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.endpoint = env("MIRO_BALL_TLS_ENDPOINT")
        cls.keys = Path(env("MIRO_BALL_KEYS"))
        cls.robots = env("MIRO_BALL_TLS_ROBOTS").split(",")

    def test_a_robot_gets_the_ball_with_its_own_keys(self):
        me = self.robots[0]
        with BallClient.connect([self.endpoint], keys_dir=self.keys / f"robot-{me}", server_timeout_s=5.0) as c:
            self.assertTrue(c.secured)
            self.assertEqual(c.robot_id, me)
            self.assertTrue(c.servers())
            s = c.wait_state(FIRST_STATE_S)
            assert_in_pitch(self, s.position_m, "ball")
            assert_good_prediction(self, s.prediction)
            assert_good_prediction(self, c.predict(1.0), horizon_s=1.0)
            # Its own intercept by default, and another robot's on asking.
            self.assertEqual(c.intercept().robot_id, me)
            other = self.robots[-1]
            self.assertEqual(c.intercept(other, speed_mps=0.5).robot_id, other)
            with self.assertRaises(QueryError):
                c.intercept("nobody")
            self.assertEqual(c.stats().rejected, {})

    def test_a_robot_not_on_the_roster_finds_no_server(self):
        intruder = env("MIRO_BALL_INTRUDER")
        t0 = time.monotonic()
        with self.assertRaises(NoServerError) as cm:
            BallClient.connect([self.endpoint], keys_dir=self.keys / f"robot-{intruder}", server_timeout_s=1.5)
        self.assertLess(time.monotonic() - t0, 2.5)
        msg = str(cm.exception)
        self.assertIn(self.endpoint, msg)
        self.assertIn("roster", msg)
        # It did get a link (its certificate is genuine), but nothing over it.
        self.assertGreaterEqual(cm.exception.linked_peers, 1)

    def test_another_authority_gets_no_link(self):
        other = env("MIRO_BALL_OTHER_KEYS")
        t0 = time.monotonic()
        with self.assertRaises(NoServerError) as cm:
            BallClient.connect([self.endpoint], keys_dir=other, server_timeout_s=1.5)
        self.assertLess(time.monotonic() - t0, 2.5)
        self.assertEqual(cm.exception.linked_peers, 0)
        self.assertIn("authority", str(cm.exception))

    def test_the_example_runs_with_keys(self):
        me = self.robots[0]
        out = subprocess.run(
            [sys.executable, str(EXAMPLE), "--connect", self.endpoint, "--keys", str(self.keys / f"robot-{me}"),
             "--for-s", "1.1"],
            capture_output=True, text=True, timeout=30,
        )
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn(f"as robot {me}", out.stdout)
        self.assertIn(f"{me} meets it at", out.stdout)


class ThroughARouter(unittest.TestCase):
    """A robot in client mode through a router (loaded with the access-control list
    `fusion-server keys` writes for it), to a secured server that has no robots yet."""

    def test_finds_the_server_before_any_ball(self):
        endpoint = env("MIRO_BALL_ROUTER_ENDPOINT")
        me = env("MIRO_BALL_TLS_ROBOTS").split(",")[0]
        t0 = time.monotonic()
        with BallClient.connect([endpoint], keys_dir=Path(env("MIRO_BALL_KEYS")) / f"robot-{me}",
                                mode="client", server_timeout_s=5.0) as c:
            self.assertLess(time.monotonic() - t0, 2.0)
            # No robots, so no estimate: no state, and the server says why.
            with self.assertRaises(NoStateError) as cm:
                c.wait_state(0.5)
            self.assertIn("present", str(cm.exception))
            with self.assertRaises(QueryError) as cm:
                c.predict(1.0)
            self.assertIn("estimate", cm.exception.server_message)
            with self.assertRaises(QueryError):
                c.intercept()
            self.assertIsNone(c.latest_state())


class NoServer(unittest.TestCase):
    def test_raises_within_the_timeout(self):
        dead = env("MIRO_BALL_DEAD_ENDPOINT")
        for timeout in (1.0, 2.0):
            t0 = time.monotonic()
            with self.assertRaises(NoServerError) as cm:
                BallClient.connect([dead], server_timeout_s=timeout)
            took = time.monotonic() - t0
            self.assertLess(took, timeout + 0.5, f"took {took:.2f} s for a {timeout} s timeout")
            self.assertGreater(took, timeout - 0.1)
            msg = str(cm.exception)
            self.assertIn(dead, msg)
            self.assertIn("fusion-server is running", msg)
            self.assertIsInstance(cm.exception, ConnectionError)

    def test_never_hangs_on_a_secured_endpoint_either(self):
        dead = env("MIRO_BALL_DEAD_ENDPOINT").replace("tcp/", "tls/")
        keys = Path(env("MIRO_BALL_KEYS")) / f"robot-{env('MIRO_BALL_TLS_ROBOTS').split(',')[0]}"
        t0 = time.monotonic()
        with self.assertRaises(NoServerError):
            BallClient.connect([dead], keys_dir=keys, server_timeout_s=1.0)
        self.assertLess(time.monotonic() - t0, 1.5)

    def test_a_tls_client_on_a_plain_server_gets_a_clear_error_fast(self):
        # The handshake never completes there: the error must still come on time.
        plain = env("MIRO_BALL_OPEN_ENDPOINT").replace("tcp/", "tls/")
        keys = Path(env("MIRO_BALL_KEYS")) / f"robot-{env('MIRO_BALL_TLS_ROBOTS').split(',')[0]}"
        t0 = time.monotonic()
        with self.assertRaises(NoServerError) as cm:
            BallClient.connect([plain], keys_dir=keys, server_timeout_s=1.0)
        self.assertLess(time.monotonic() - t0, 1.5)
        self.assertIn("no link", str(cm.exception))


class ServerGoesAway(unittest.TestCase):
    """A server of the test's own (``FUSION_SERVER``), without robots, that stops."""

    def test_queries_then_say_no_reply(self):
        binary = env("FUSION_SERVER")
        port, http = free_port(), free_port()
        server = subprocess.Popen(
            [binary, "serve", "--open", "--id", "going", "--listen", f"tcp/127.0.0.1:{port}",
             "--http", f"127.0.0.1:{http}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        try:
            with BallClient.connect([f"tcp/127.0.0.1:{port}"], server_timeout_s=10.0) as c:
                # The client may have found the server by its probe query before the
                # server's liveliness token reached it.
                deadline = time.monotonic() + 5.0
                while not c.servers() and time.monotonic() < deadline:
                    time.sleep(0.05)
                self.assertEqual(c.servers(), ["going"])
                with self.assertRaises(QueryError) as cm:
                    c.predict(1.0)
                self.assertIn("no ball estimate", cm.exception.server_message)
                server.terminate()
                server.wait(10)
                deadline = time.monotonic() + 5.0
                while c.servers() and time.monotonic() < deadline:
                    time.sleep(0.05)
                self.assertEqual(c.servers(), [])
                t0 = time.monotonic()
                with self.assertRaises(NoReplyError):
                    c.predict(1.0, timeout_s=0.5)
                self.assertLess(time.monotonic() - t0, 1.0)
                t0 = time.monotonic()
                with self.assertRaises(NoStateError) as cm:
                    c.wait_state(0.3)
                self.assertLess(time.monotonic() - t0, 1.0)
                # Whether the client has yet noticed the server's token gone is a race;
                # either way the message names what is missing.
                self.assertIn("no ball state on rf/ball/state", str(cm.exception))
        finally:
            server.kill()
            server.wait()


class Closing(unittest.TestCase):
    def test_closed_client_refuses_calls(self):
        c = BallClient.connect([env("MIRO_BALL_OPEN_ENDPOINT")])
        c.wait_state(FIRST_STATE_S)
        t0 = time.monotonic()
        c.close()
        c.close()
        self.assertLess(time.monotonic() - t0, 2.5)
        self.assertTrue(c.closed)
        for call in (c.latest_state, lambda: c.wait_state(0.1), lambda: c.predict(1.0),
                     lambda: c.intercept("miro1"), lambda: c.on_state(print)):
            with self.assertRaises(ClientClosedError):
                call()

    def test_close_wakes_a_waiting_thread(self):
        c = BallClient.connect([env("MIRO_BALL_OPEN_ENDPOINT")])
        c.wait_state(FIRST_STATE_S)
        result = []

        def waiter():
            try:
                for _ in c.states(timeout_s=30.0):
                    pass
                result.append("ended")
            except Exception as e:  # pragma: no cover - shown by the assertion
                result.append(e)

        t = threading.Thread(target=waiter)
        t.start()
        time.sleep(0.3)
        c.close()
        t.join(3.0)
        self.assertFalse(t.is_alive())
        self.assertEqual(result, ["ended"])


if __name__ == "__main__":
    unittest.main()
