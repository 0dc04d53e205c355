"""Parsing, validation and interpolation: plain Python, no network."""

import copy
import json
import math
import time
import unittest

from miro_ball import (
    BallState,
    Checks,
    MessageError,
    Pitch,
    parse_ball_state,
    parse_intercept,
    parse_prediction,
    s_to_stamp,
    stamp_to_s,
)

from support import BALL_STATE, DELETE, INTERCEPT, PREDICTION, dumps, offline_client, state


class ParsesTheProtocolExamples(unittest.TestCase):
    def test_ball_state(self):
        s = parse_ball_state(dumps(BALL_STATE))
        self.assertIsInstance(s, BallState)
        self.assertEqual(s.stamp, 1700000000000000000)
        self.assertIsInstance(s.stamp, int)
        self.assertEqual(s.position_m, (1.2, 0.4))
        self.assertEqual(s.velocity_mps, (1.1, 0.3))
        self.assertEqual(len(s.covariance), 16)
        self.assertEqual(s.status, "tracking")
        self.assertEqual(s.last_seen, 1699999999965000000)
        self.assertEqual(s.contributors, ("miro1", "miro3"))
        self.assertAlmostEqual(s.existence, 0.97)
        self.assertEqual(s.model.decel_samples, 12)
        self.assertAlmostEqual(s.model.slide_decel_mps2, 2.8)
        self.assertEqual((s.model.bounces_seen, s.model.kicks_inferred), (9, 2))
        p = s.prediction
        self.assertEqual([x.t_s for x in p.samples], [0.0, 1.0, 2.0])
        self.assertEqual(p.bounces[0].wall, "x_max")
        self.assertEqual(p.stop.position_m, (1.6, 0.77))
        self.assertEqual(p.samples[1].covariance_m2, (0.004, 0.001, 0.001, 0.002))
        self.assertEqual(p.stop.covariance_m2, (0.015, 0.002, 0.002, 0.007))
        mid = p.covariance_at(1.5)
        self.assertAlmostEqual(mid[0], 0.008)
        self.assertAlmostEqual(mid[3], 0.004)
        self.assertEqual(p.covariance_at(3.0), p.stop.covariance_m2)
        self.assertAlmostEqual(s.speed_mps, math.hypot(1.1, 0.3))
        self.assertAlmostEqual(s.position_std_m[0], 0.03)

    def test_text_and_bytes_alike(self):
        self.assertEqual(parse_ball_state(json.dumps(BALL_STATE)), parse_ball_state(dumps(BALL_STATE)))

    def test_prediction_and_intercept(self):
        p = parse_prediction(dumps(PREDICTION))
        self.assertEqual(p.horizon_s, 2.0)
        i = parse_intercept(dumps(INTERCEPT))
        self.assertEqual(i.robot_id, "miro2")
        self.assertTrue(i.reachable_in_motion)
        self.assertAlmostEqual(i.probability, 0.82)
        self.assertIsNone(parse_intercept(dumps(dict(INTERCEPT, probability=None))).probability)
        self.assertAlmostEqual(i.meet_time_s, 1700000000.0 + 1.35)
        self.assertAlmostEqual(i.time_to_meet_s(now_s=1700000000.0), 1.35, places=5)

    def test_optional_fields_take_their_defaults(self):
        s = state(existence=DELETE, last_seen=None)
        del s["model"]["tangential_retention"]
        del s["model"]["slide_decel_mps2"]
        del s["model"]["bounces_seen"]
        del s["model"]["kicks_inferred"]
        s["prediction"]["stop"] = None
        b = parse_ball_state(dumps(s))
        self.assertEqual(b.existence, 1.0)
        self.assertIsNone(b.last_seen)
        self.assertIsNone(b.last_seen_s)
        self.assertEqual(b.model.tangential_retention, 0.85)
        self.assertEqual(b.model.slide_decel_mps2, 3.0)
        self.assertEqual((b.model.bounces_seen, b.model.kicks_inferred), (0, 0))
        self.assertIsNone(b.prediction.stop)
        del s["prediction"]["stop"]
        self.assertIsNone(parse_ball_state(dumps(s)).prediction.stop)

    def test_stamps_stay_exact(self):
        odd = 1796472211909827905  # not a multiple of 256: a float would round it
        b = parse_ball_state(dumps(state(stamp=odd)))
        self.assertEqual(b.stamp, odd)
        self.assertAlmostEqual(b.stamp_s, 1796472211.909828, places=5)
        self.assertEqual(s_to_stamp(stamp_to_s(1700000000000000000)), 1700000000000000000)

    def test_age(self):
        now = time.time()
        b = parse_ball_state(dumps(state(stamp=s_to_stamp(now - 0.25))))
        self.assertAlmostEqual(b.age_s(now_s=now), 0.25, places=6)


class RejectsInvalidMessages(unittest.TestCase):
    def reason(self, payload, checks=Checks(), parse=parse_ball_state):
        with self.assertRaises(MessageError) as cm:
            parse(payload if isinstance(payload, (bytes, str)) else dumps(payload), checks)
        self.assertIsInstance(cm.exception, ValueError)
        return cm.exception.reason

    def test_not_json(self):
        self.assertEqual(self.reason(b"{not json"), "not_json")
        self.assertEqual(self.reason(b"\xff\xfe"), "not_json")
        self.assertEqual(self.reason(b"[1, 2]"), "not_json")
        self.assertEqual(self.reason(b""), "not_json")

    def test_missing_unknown_and_mistyped_fields(self):
        self.assertEqual(self.reason(state(position_m=DELETE)), "not_json")
        self.assertEqual(self.reason(state(position_m=[1.0])), "not_json")
        self.assertEqual(self.reason(state(position_m=[True, 0.0])), "not_json")
        self.assertEqual(self.reason(state(stamp=1.7e18)), "not_json")
        self.assertEqual(self.reason(state(stamp=-1)), "not_json")
        self.assertEqual(self.reason(state(status="rolling")), "not_json")
        self.assertEqual(self.reason(state(contributors=["miro1", 3])), "not_json")
        # Fields this client does not know (a newer server's) are ignored.
        newer = state(spin=[0.0, 1.0])
        newer["prediction"]["samples"][1]["spin"] = 0.0
        self.assertEqual(parse_ball_state(dumps(newer)).position_m, (1.2, 0.4))
        wall = state()
        wall["prediction"]["bounces"][0]["wall"] = "goal"
        self.assertEqual(self.reason(wall), "not_json")

    def test_predicted_covariances_are_checked(self):
        bad = state()
        bad["prediction"]["samples"][1]["covariance_m2"] = [0.004, 0.001, 0.002, 0.002]
        self.assertEqual(self.reason(bad), "covariance_asymmetric")
        bad["prediction"]["samples"][1]["covariance_m2"] = [0.001, 0.002, 0.002, 0.001]
        self.assertEqual(self.reason(bad), "covariance_not_pd")
        bad["prediction"]["samples"][1]["covariance_m2"] = [0.001, 0.0]
        self.assertEqual(self.reason(bad), "not_json")
        old = state()
        for smp in old["prediction"]["samples"]:
            del smp["covariance_m2"]
        del old["prediction"]["stop"]["covariance_m2"]
        p = parse_ball_state(dumps(old)).prediction
        self.assertIsNone(p.samples[0].covariance_m2)
        self.assertIsNone(p.covariance_at(1.0))

    def test_nan_literals_are_not_json(self):
        text = json.dumps(BALL_STATE).replace("0.97", "NaN")
        self.assertEqual(self.reason(text), "not_json")

    def test_version_is_read_first(self):
        self.assertEqual(self.reason(state(version=DELETE)), "no_version")
        self.assertEqual(self.reason(state(version="1")), "no_version")
        self.assertEqual(self.reason(state(version=True)), "no_version")
        # A version 2 with fields this client does not know: the version decides.
        self.assertEqual(self.reason(state(version=2, spin=[0.0, 1.0])), "version")
        inner = state()
        inner["prediction"]["version"] = 2
        self.assertEqual(self.reason(inner), "version")

    def test_non_finite(self):
        text = json.dumps(BALL_STATE).replace("0.97", "1e400")
        self.assertEqual(self.reason(text), "non_finite")

    def test_robot_ids(self):
        self.assertEqual(self.reason(state(contributors=["miro 1"])), "robot_id")
        bad = dict(INTERCEPT, robot_id="x" * 65)
        with self.assertRaises(MessageError) as cm:
            parse_intercept(dumps(bad))
        self.assertEqual(cm.exception.reason, "robot_id")

    def test_covariance(self):
        c = list(BALL_STATE["covariance"])
        c[1] = 0.0002  # (0,1) no longer equals (1,0)
        self.assertEqual(self.reason(state(covariance=c)), "covariance_asymmetric")
        c = list(BALL_STATE["covariance"])
        c[0] = -0.0009
        self.assertEqual(self.reason(state(covariance=c)), "covariance_not_pd")
        self.assertEqual(self.reason(state(covariance=[0.0] * 16)), "covariance_not_pd")
        # Symmetric with a negative eigenvalue: only the factorisation finds it.
        c = [0.0] * 16
        c[0], c[1], c[4], c[5], c[10], c[15] = 1.0, 2.0, 2.0, 1.0, 1.0, 1.0
        self.assertEqual(self.reason(state(covariance=c)), "covariance_not_pd")

    def test_outside_pitch(self):
        self.assertEqual(self.reason(state(position_m=[3.2, 0.0])), "outside_pitch")
        # Within the 1 m tolerance it passes; a larger pitch takes it; no pitch, no check.
        parse_ball_state(dumps(state(position_m=[2.5, 0.0])))
        parse_ball_state(dumps(state(position_m=[3.2, 0.0])), Checks(pitch=Pitch(6.0, 4.0)))
        parse_ball_state(dumps(state(position_m=[30.0, 0.0])), Checks(pitch=None))
        far = state()
        far["prediction"]["samples"][2]["position_m"] = [0.0, 2.5]
        self.assertEqual(self.reason(far), "outside_pitch")

    def test_stamp_only_with_a_skew(self):
        old = dumps(state())  # 2023: far from this machine's clock
        parse_ball_state(old)  # no skew given: accepted (a replayed match)
        self.assertEqual(self.reason(old, Checks(max_clock_skew_s=10.0)), "stamp")
        now_ns = s_to_stamp(time.time())
        fresh = state(stamp=now_ns)
        fresh["prediction"]["stamp"] = now_ns
        parse_ball_state(dumps(fresh), Checks(max_clock_skew_s=10.0))

    def test_out_of_range(self):
        self.assertEqual(self.reason(state(existence=1.5)), "out_of_range")
        s = state()
        s["model"]["wall_restitution"] = 1.2
        self.assertEqual(self.reason(s), "out_of_range")
        s = state()
        s["prediction"]["horizon_s"] = 4000.0
        self.assertEqual(self.reason(s), "out_of_range")
        self.assertEqual(self.reason(dict(INTERCEPT, t_s=-1.0), parse=lambda p, c: parse_intercept(p)), "out_of_range")
        self.assertEqual(
            self.reason(dict(INTERCEPT, probability=1.5), parse=lambda p, c: parse_intercept(p)), "out_of_range"
        )

    def test_path_order(self):
        s = state()
        s["prediction"]["samples"].reverse()
        self.assertEqual(self.reason(s), "bad_path")
        s["prediction"]["samples"] = []
        self.assertEqual(self.reason(s), "bad_path")
        p = copy.deepcopy(PREDICTION)
        p["bounces"] = [dict(p["bounces"][0], t_s=1.5), p["bounces"][0]]
        self.assertEqual(self.reason(p, parse=parse_prediction), "bad_path")


class Interpolates(unittest.TestCase):
    def setUp(self):
        self.p = parse_prediction(dumps(PREDICTION))

    def test_at_the_samples_and_between(self):
        for s in self.p.samples:
            if s.t_s < self.p.stop.t_s:
                self.assertEqual(self.p.position_at(s.t_s), s.position_m)
        # Between the bounce (0.62 s) and the sample at 1.0 s: on the straight line.
        x, y = self.p.position_at(0.81)
        a = (0.81 - 0.62) / (1.0 - 0.62)
        self.assertAlmostEqual(x, 1.91 + a * (1.83 - 1.91))
        self.assertAlmostEqual(y, 0.58 + a * (0.64 - 0.58))

    def test_turns_at_the_bounce(self):
        self.assertEqual(self.p.position_at(0.62), (1.91, 0.58))
        x, _ = self.p.position_at(0.31)
        self.assertAlmostEqual(x, 1.2 + 0.5 * (1.91 - 1.2))
        self.assertEqual(self.p.next_bounce().wall, "x_max")
        self.assertIsNone(self.p.next_bounce(after_t_s=0.7))

    def test_ends(self):
        self.assertEqual(self.p.position_at(-1.0), (1.2, 0.4))
        # The stop (2.4 s) lies beyond the horizon (2.0 s): the last sample until then.
        self.assertEqual(self.p.position_at(2.2), (1.62, 0.76))
        self.assertEqual(self.p.position_at(2.4), (1.6, 0.77))
        self.assertEqual(self.p.position_at(100.0), (1.6, 0.77))
        self.assertEqual(self.p.velocity_at(3.0), (0.0, 0.0))
        with self.assertRaises(ValueError):
            self.p.position_at(float("nan"))

    def test_velocity(self):
        self.assertEqual(self.p.velocity_at(0.0), (1.1, 0.3))
        # The bounce at 0.62 s lies between the samples at 0 and 1 s: the velocity jumps.
        self.assertEqual(self.p.velocity_at(0.5), (1.1, 0.3))
        self.assertEqual(self.p.velocity_at(0.7), (-0.35, 0.2))
        vx, vy = self.p.velocity_at(1.5)
        self.assertAlmostEqual(vx, (-0.35 + -0.08) / 2)
        self.assertAlmostEqual(vy, (0.2 + 0.04) / 2)

    def test_at_wall_clock_time(self):
        s = parse_ball_state(dumps(BALL_STATE))
        # Float seconds since 1970 resolve about 0.2 us: close, not equal.
        for got, want in [(s.position_at_time(1700000000.0 + 0.62), (1.91, 0.58)),
                          (s.prediction.position_at_time(1700000000.0 + 5.0), (1.6, 0.77))]:
            self.assertAlmostEqual(got[0], want[0], places=5)
            self.assertAlmostEqual(got[1], want[1], places=5)


class CountsAndSkipsBadStates(unittest.TestCase):
    def test_bad_states_are_counted_and_skipped(self):
        c = offline_client()
        seen = []
        c.on_state(seen.append)
        self.assertIsNone(c.latest_state())
        good = c.feed_state(dumps(BALL_STATE), server_id="s1")
        self.assertIsNotNone(good)
        self.assertEqual(good.server_id, "s1")
        self.assertIsNotNone(good.received_s)
        with self.assertLogs("miro_ball", "WARNING") as logs:
            for bad in (b"garbage", dumps(state(version=7)), dumps(state(existence=2.0)), b"{}"):
                self.assertIsNone(c.feed_state(bad))
            self.assertIsNone(c.feed_state(b"garbage again"))
        # One warning per reason; the repeats are only counted.
        self.assertEqual(len(logs.records), 4)
        # The good state is still the latest; the bad ones reached no callback.
        self.assertIs(c.latest_state(), good)
        self.assertEqual(seen, [good])
        st = c.stats()
        self.assertEqual(st.states_received, 6)
        self.assertEqual(st.states_accepted, 1)
        self.assertEqual(st.states_rejected, 5)
        self.assertEqual(st.rejected, {"not_json": 2, "version": 1, "out_of_range": 1, "no_version": 1})
        self.assertIn("not JSON", st.last_rejection)

    def test_a_raising_callback_is_counted(self):
        c = offline_client()

        def boom(_):
            raise RuntimeError("a bug in the behaviour")

        c.on_state(boom)
        with self.assertLogs("miro_ball", "ERROR"):
            self.assertIsNotNone(c.feed_state(dumps(BALL_STATE)))
            self.assertIsNotNone(c.feed_state(dumps(BALL_STATE)))
        self.assertEqual(c.stats().callback_errors, 2)
        c.remove_callback(boom)
        c.feed_state(dumps(BALL_STATE))
        self.assertEqual(c.stats().callback_errors, 2)


if __name__ == "__main__":
    unittest.main()
