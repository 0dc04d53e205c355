"""Endpoints, key folders and the Zenoh settings: no network (nothing is connected)."""

import json
import os
import tempfile
import time
import unittest
from pathlib import Path

import zenoh

from miro_ball import BallClient, ConfigError
from miro_ball import net

PEM_CERT = "-----BEGIN CERTIFICATE-----\nMIIB\n-----END CERTIFICATE-----\n"
PEM_KEY = "-----BEGIN PRIVATE KEY-----\nMIGH\n-----END PRIVATE KEY-----\n"


def make_key_folder(root, robot="miro1"):
    d = Path(root) / f"robot-{robot}"
    d.mkdir(parents=True)
    (d / "ca.pem").write_text(PEM_CERT)
    (d / "cert.pem").write_text(PEM_CERT)
    (d / "key.pem").write_text(PEM_KEY)
    return d


class Endpoints(unittest.TestCase):
    def test_good(self):
        self.assertEqual(net.check_endpoint("tcp/127.0.0.1:7447"), ("tcp", "127.0.0.1", 7447))
        self.assertEqual(net.check_endpoint("tls/pitch-server.local:7447"), ("tls", "pitch-server.local", 7447))
        self.assertEqual(net.check_endpoint("tcp/[::1]:7447"), ("tcp", "[::1]", 7447))
        self.assertEqual(net.check_endpoints("tcp/127.0.0.1:1"), ("tcp/127.0.0.1:1",))

    def test_bad(self):
        for bad in ["127.0.0.1:7447", "tcp/127.0.0.1", "tcp/:1", "tcp/h:99999", "tcp/h:0", "tcp/h:http",
                    "/h:1", "", "tcp/ h:1", 7447, None]:
            with self.assertRaises(ConfigError, msg=repr(bad)) as cm:
                net.check_endpoints([bad])
            self.assertIn("endpoint", str(cm.exception))
        with self.assertRaises(ConfigError):
            net.check_endpoints([])

    def test_connect_refuses_them_before_the_network(self):
        t0 = time.monotonic()
        with self.assertRaises(ConfigError) as cm:
            BallClient.connect(["tcp/127.0.0.1"])
        self.assertIn("'tcp/127.0.0.1'", str(cm.exception))
        self.assertIsInstance(cm.exception, ValueError)
        for kwargs in ({"prefix": "rf/"}, {"prefix": "r f"}, {"server_timeout_s": 0},
                       {"query_timeout_s": float("nan")}, {"robot_id": "miro 1"}, {"mode": "router"}):
            with self.assertRaises(ConfigError, msg=repr(kwargs)):
                BallClient.connect(["tcp/127.0.0.1:1"], **kwargs)
        self.assertLess(time.monotonic() - t0, 0.5)

    def test_prefix(self):
        for good in ["rf", "lab/pitch_2", "a-b/c"]:
            self.assertEqual(net.check_prefix(good), good)
        for bad in ["", "rf/", "/rf", "rf/*", "rf/**", "a b", None]:
            with self.assertRaises(ConfigError, msg=repr(bad)):
                net.check_prefix(bad)


class KeyFolders(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.root = Path(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def test_a_complete_folder(self):
        d = make_key_folder(self.root)
        files = net.check_keys_dir(d)
        self.assertEqual(files.key, d / "key.pem")
        self.assertEqual(net.robot_id_of_keys_dir(d), "miro1")
        self.assertIsNone(net.robot_id_of_keys_dir(self.root))

    def test_a_missing_file_is_named(self):
        d = make_key_folder(self.root)
        os.remove(d / "key.pem")
        with self.assertRaises(ConfigError) as cm:
            BallClient.connect(["tls/127.0.0.1:1"], keys_dir=d)
        self.assertIn(str(d / "key.pem"), str(cm.exception))
        self.assertIn("missing", str(cm.exception))

    def test_a_file_that_is_not_pem(self):
        d = make_key_folder(self.root)
        (d / "cert.pem").write_text("hello")
        with self.assertRaises(ConfigError) as cm:
            net.check_keys_dir(d)
        self.assertIn("cert.pem", str(cm.exception))

    def test_no_folder_and_the_whole_network_folder(self):
        with self.assertRaises(ConfigError) as cm:
            net.check_keys_dir(self.root / "nowhere")
        self.assertIn("does not exist", str(cm.exception))
        make_key_folder(self.root, "miro1")
        make_key_folder(self.root, "miro2")
        with self.assertRaises(ConfigError) as cm:
            net.check_keys_dir(self.root)
        self.assertIn("robot-miro1", str(cm.exception))

    def test_tls_and_plain_endpoints_do_not_mix(self):
        d = make_key_folder(self.root)
        with self.assertRaises(ConfigError) as cm:
            BallClient.connect(["tcp/127.0.0.1:7447"], keys_dir=d)
        self.assertIn("not TLS", str(cm.exception))
        with self.assertRaises(ConfigError) as cm:
            BallClient.connect(["tls/127.0.0.1:7447"])
        self.assertIn("keys_dir", str(cm.exception))


class ZenohSettings(unittest.TestCase):
    """The settings every process of the product uses, minus listening."""

    def apply(self, settings):
        c = zenoh.Config()
        for k, v in settings:
            c.insert_json5(k, v)
        return c

    def get(self, c, key):
        v = c.get_json(key)
        return json.loads(v) if isinstance(v, str) else v

    def test_open(self):
        c = self.apply(net.zenoh_settings(["tcp/127.0.0.1:7447"]))
        self.assertEqual(self.get(c, "mode"), "peer")
        self.assertEqual(self.get(c, "listen/endpoints"), [])
        self.assertEqual(self.get(c, "connect/endpoints"), ["tcp/127.0.0.1:7447"])
        self.assertIs(self.get(c, "scouting/multicast/enabled"), False)
        self.assertIs(self.get(c, "scouting/gossip/enabled"), False)
        self.assertIs(self.get(c, "adminspace/enabled"), False)
        self.assertEqual(self.get(c, "connect/retry")["period_max_ms"], 500)

    def test_secured(self):
        with tempfile.TemporaryDirectory() as tmp:
            d = make_key_folder(tmp)
            c = self.apply(net.zenoh_settings(["tls/127.0.0.1:7447"], net.check_keys_dir(d), mode="client"))
            t = "transport/link/tls/"
            self.assertEqual(self.get(c, "mode"), "client")
            self.assertIs(self.get(c, t + "enable_mtls"), True)
            self.assertIs(self.get(c, t + "verify_name_on_connect"), True)
            for key, name in [("root_ca_certificate", "ca.pem"), ("connect_certificate", "cert.pem"),
                              ("connect_private_key", "key.pem"), ("listen_certificate", "cert.pem"),
                              ("listen_private_key", "key.pem")]:
                self.assertEqual(self.get(c, t + key), str((d / name).resolve()))


if __name__ == "__main__":
    unittest.main()
