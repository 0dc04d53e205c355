"""How the client joins the Zenoh network: the same session settings as every process of
the product (the robot agents, the fusion server, the simulated robots), except that the
client never listens.

- peer mode (or ``client`` mode, through a ``zenohd`` router);
- exactly the given ``connect`` endpoints, no listening endpoint;
- multicast and gossip scouting off: at a tournament many teams share one network, and
  scouting would link up with anyone's Zenoh processes;
- a connect endpoint that is not up yet keeps being retried;
- no admin space;
- with a key folder, TLS with mutual authentication on every link: the folder's
  certificate proves who this robot is, and the server's host name is checked against
  its certificate.

Nothing here opens a connection: :func:`zenoh_settings` returns the configuration as
(key, JSON) pairs, which :class:`~miro_ball.client.BallClient` applies.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, List, Optional, Sequence, Tuple, Union

from .errors import ConfigError
from .messages import is_valid_id

#: Default endpoint: a fusion server on this machine.
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"

#: Default key prefix.
DEFAULT_PREFIX = "rf"

_PREFIX = re.compile(r"[A-Za-z0-9_-]+(/[A-Za-z0-9_-]+)*")

PathLike = Union[str, "os.PathLike[str]"]


def check_endpoint(endpoint: object) -> Tuple[str, str, int]:
    """Checks that ``endpoint`` is ``PROTOCOL/HOST:PORT`` (e.g. ``tcp/127.0.0.1:7447``, or
    ``tls/pitch-server.local:7447``); returns (protocol, host, port). Raises
    :class:`ConfigError` otherwise."""
    if not isinstance(endpoint, str):
        raise ConfigError(f"a Zenoh endpoint must be a string like {DEFAULT_ENDPOINT!r}, not {endpoint!r}")
    bad = ConfigError(
        f"Zenoh endpoint {endpoint!r} is not of the form PROTOCOL/HOST:PORT "
        f"(e.g. {DEFAULT_ENDPOINT!r} or 'tls/pitch-server.local:7447')"
    )
    proto, sep, rest = endpoint.partition("/")
    if not sep or not proto or any(c.isspace() for c in endpoint):
        raise bad
    addr = re.split(r"[?#]", rest, maxsplit=1)[0]
    host, sep, port = addr.rpartition(":")
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise bad
    return proto, host, int(port)


def check_prefix(prefix: object) -> str:
    """Checks a key prefix: one or more chunks of ``A-Z a-z 0-9 _ -`` separated by ``/``."""
    if not isinstance(prefix, str) or not _PREFIX.fullmatch(prefix):
        raise ConfigError(
            f"key prefix {prefix!r} is not one or more chunks of A-Z, a-z, 0-9, _ and - "
            "separated by / (the default is 'rf'; it must be the fusion server's --prefix)"
        )
    return prefix


def check_endpoints(endpoints: Union[str, Iterable[str]]) -> Tuple[str, ...]:
    """A list of endpoints (a single string is taken as one endpoint), each checked."""
    if isinstance(endpoints, str):
        endpoints = [endpoints]
    try:
        eps = tuple(endpoints)
    except TypeError:
        raise ConfigError(f"endpoints must be a list of strings like [{DEFAULT_ENDPOINT!r}], not {endpoints!r}") from None
    if not eps:
        raise ConfigError(f"give at least one Zenoh endpoint to connect to, e.g. {DEFAULT_ENDPOINT!r}")
    for e in eps:
        check_endpoint(e)
    return eps


@dataclass(frozen=True)
class TlsFiles:
    """A node's TLS files (PEM), as ``fusion-server keys`` writes them in each node's
    folder: the network's authority ``ca.pem``, the node's ``cert.pem`` and ``key.pem``."""

    ca: Path
    cert: Path
    key: Path

    @staticmethod
    def in_dir(keys_dir: PathLike) -> "TlsFiles":
        d = Path(keys_dir)
        return TlsFiles(d / "ca.pem", d / "cert.pem", d / "key.pem")


# What each file must hold, to catch a wrong file before Zenoh quietly fails on it.
_PEM_MARKERS = {
    "ca": ("-----BEGIN CERTIFICATE-----",),
    "cert": ("-----BEGIN CERTIFICATE-----",),
    "key": ("-----BEGIN PRIVATE KEY-----", "-----BEGIN EC PRIVATE KEY-----", "-----BEGIN RSA PRIVATE KEY-----"),
}


def check_keys_dir(keys_dir: PathLike) -> TlsFiles:
    """Checks a robot's key folder (``robot-{id}`` written by ``fusion-server keys``): it
    exists, and ``ca.pem``, ``cert.pem`` and ``key.pem`` are there, readable and PEM."""
    d = Path(keys_dir)
    hint = (
        "give the robot's own key folder, the robot-{id} folder `fusion-server keys --out DIR "
        "--robots ID` writes (it holds ca.pem, cert.pem and key.pem)"
    )
    if not d.is_dir():
        raise ConfigError(f"key folder {str(d)!r} does not exist or is not a folder: {hint}")
    files = TlsFiles.in_dir(d)
    if not files.ca.exists() and not files.cert.exists():
        nodes = sorted(p.name for p in d.iterdir() if p.is_dir() and p.name.startswith("robot-"))
        if nodes:
            raise ConfigError(
                f"{str(d)!r} is the whole network's key folder; give one robot's folder in it, "
                f"e.g. {str(d / nodes[0])!r}"
            )
    for kind, path in (("ca", files.ca), ("cert", files.cert), ("key", files.key)):
        try:
            text = path.read_text(encoding="ascii", errors="replace")
        except FileNotFoundError:
            raise ConfigError(f"TLS file {str(path)!r} is missing: {hint}") from None
        except OSError as e:
            raise ConfigError(f"TLS file {str(path)!r} cannot be read: {e.strerror or e}") from None
        if not any(m in text for m in _PEM_MARKERS[kind]):
            want = "a certificate" if kind != "key" else "a private key"
            raise ConfigError(f"TLS file {str(path)!r} does not hold {want} in PEM form: {hint}")
    return files


def robot_id_of_keys_dir(keys_dir: PathLike) -> Optional[str]:
    """The robot id a ``robot-{id}`` key folder is named after, or ``None``."""
    name = Path(keys_dir).resolve().name
    if name.startswith("robot-") and is_valid_id(name[len("robot-"):]):
        return name[len("robot-"):]
    return None


def check_secured_endpoints(endpoints: Sequence[str], tls: Optional[TlsFiles]) -> None:
    """With keys every endpoint must be ``tls/``; without keys none may be."""
    for e in endpoints:
        is_tls = e.startswith("tls/")
        if tls is not None and not is_tls:
            raise ConfigError(
                f"Zenoh endpoint {e!r} is not TLS: with a key folder every endpoint must be "
                "tls/HOST:PORT (the secured server listens on tls/...)"
            )
        if tls is None and is_tls:
            raise ConfigError(
                f"Zenoh endpoint {e!r} is TLS but no key folder is given: pass keys_dir=, the "
                "robot's robot-{id} folder from `fusion-server keys`"
            )


def zenoh_settings(endpoints: Sequence[str], tls: Optional[TlsFiles] = None, mode: str = "peer") -> List[Tuple[str, str]]:
    """The Zenoh configuration as (key, JSON value) pairs, in the order to insert them."""
    if mode not in ("peer", "client"):
        raise ConfigError(f"Zenoh mode {mode!r} is not peer or client")

    def j(v: Any) -> str:
        return json.dumps(v)

    out = [
        ("mode", j(mode)),
        ("listen/endpoints", j([])),
        ("connect/endpoints", j(list(endpoints))),
        ("scouting/multicast/enabled", j(False)),
        ("scouting/gossip/enabled", j(False)),
        # Keep retrying a connect endpoint that is not up yet, or gone (a server restarted):
        # after 0.1 s, then half as long again each time up to 0.5 s, so the client is back
        # within a second of the server listening again without hammering one that is down.
        ("connect/exit_on_failure", j(False)),
        ("connect/retry", j({"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 1.5})),
        ("adminspace/enabled", j(False)),
    ]
    if tls is not None:
        t = "transport/link/tls"
        ca, cert, key = (str(Path(p).resolve()) for p in (tls.ca, tls.cert, tls.key))
        out += [
            (f"{t}/root_ca_certificate", j(ca)),
            (f"{t}/listen_certificate", j(cert)),
            (f"{t}/listen_private_key", j(key)),
            (f"{t}/connect_certificate", j(cert)),
            (f"{t}/connect_private_key", j(key)),
            # Both ends prove themselves, and the one connecting checks the other's name.
            (f"{t}/enable_mtls", j(True)),
            (f"{t}/verify_name_on_connect", j(True)),
        ]
    return out
