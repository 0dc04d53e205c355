"""The ball client: one Zenoh session to the fusion server, the latest shared ball state,
and prediction and intercept queries."""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Tuple, Union

from . import net
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
    DEFAULT_CHECKS,
    BallState,
    Checks,
    Intercept,
    Prediction,
    is_valid_id,
    parse_ball_state,
    parse_intercept,
    parse_prediction,
)

log = logging.getLogger("miro_ball")

StateCallback = Callable[[BallState], Any]

#: How long :meth:`BallClient.close` waits for Zenoh to shut the session down before it
#: leaves that to a background thread (a link stuck in a TLS handshake can take seconds).
_CLOSE_WAIT_S = 2.0
#: The same after a failed connect, which must raise on time.
_FAILED_CLOSE_WAIT_S = 0.2

#: While it waits for a server, the client asks ``{prefix}/ball/predict`` this often when
#: no server token has been seen, and waits this long for an answer.
_PROBE_PERIOD_S = 0.25
_PROBE_TIMEOUT_S = 0.5


@dataclass(frozen=True)
class ClientStats:
    """What the client has received so far (a snapshot)."""

    states_received: int  #: payloads received on ``{prefix}/ball/state``
    states_accepted: int  #: of them, valid states
    rejected: Dict[str, int] = field(default_factory=dict)  #: the others, by reason
    last_rejection: Optional[str] = None  #: the last rejection's explanation
    callback_errors: int = 0  #: exceptions raised by :meth:`BallClient.on_state` callbacks

    @property
    def states_rejected(self) -> int:
        return sum(self.rejected.values())


def _close_in_background(session: Any, wait_s: float) -> None:
    """Closes a Zenoh session, waiting at most ``wait_s`` for it.

    Closing takes milliseconds, except when a link is stuck half-way (a TLS handshake
    with a plain TCP port holds it for Zenoh's open timeout, about 10 s): then the caller
    goes on and the close finishes in its thread. The thread is not a daemon: a daemon
    thread still inside Zenoh when the interpreter shuts down aborts the process, so
    Python's exit rather waits for it."""
    t = threading.Thread(target=_quiet_close, args=(session,), name="miro_ball-close", daemon=False)
    t.start()
    t.join(wait_s)


def _quiet_close(session: Any) -> None:
    try:
        session.close()
    except Exception:  # pragma: no cover - closing twice, or a session already gone
        pass


def _format_number(x: float) -> str:
    """A number as the server's parameter parser reads it (``repr`` of a float)."""
    return repr(float(x))


class BallClient:
    """A connection to the team's fusion server, from a robot's own Python program.

    Make one with :meth:`connect`; use it as a context manager or call :meth:`close`.
    Once connected the client keeps the most recent ball state as it arrives (about 30
    times a second), so :meth:`latest_state` never waits. Queries (:meth:`predict`,
    :meth:`intercept`) go to the server and wait for its answer, at most
    ``query_timeout_s``.

    Thread-safe: any thread may call any method. Callbacks given to :meth:`on_state` run
    on Zenoh's own thread, one state at a time; keep them short.
    """

    def __init__(self, *_: Any, **__: Any):
        raise TypeError("use BallClient.connect(...) to make a client")

    # ------------------------------------------------------------------ connecting

    @classmethod
    def connect(
        cls,
        endpoints: Union[str, Iterable[str]] = (net.DEFAULT_ENDPOINT,),
        keys_dir: Optional[net.PathLike] = None,
        prefix: str = net.DEFAULT_PREFIX,
        server_timeout_s: float = 5.0,
        query_timeout_s: float = 1.0,
        robot_id: Optional[str] = None,
        mode: str = "peer",
        checks: Checks = DEFAULT_CHECKS,
    ) -> "BallClient":
        """Joins the network and waits until a fusion server is present.

        ``endpoints``: the Zenoh endpoints to connect to (``tcp/HOST:PORT``, or
        ``tls/HOST:PORT`` on a secured network): the fusion server's ``--listen``
        endpoint, or a ``zenohd`` router's (then with ``mode="client"``). The client
        connects only; it never listens and never scouts.

        ``keys_dir``: on a secured network, this robot's own key folder (``robot-{id}``
        from ``fusion-server keys``, holding ``ca.pem``, ``cert.pem``, ``key.pem``); every
        endpoint must then be ``tls/``. ``None`` for an open network.

        ``prefix``: the key prefix, as the server's ``--prefix`` (default ``rf``).

        ``server_timeout_s``: how long to wait for a fusion server (its liveliness token
        ``{prefix}/servers/*``, a ball state, or an answer to a probe query) before raising
        :class:`NoServerError`.

        ``query_timeout_s``: default timeout of :meth:`predict` and :meth:`intercept`.

        ``robot_id``: this robot's id, the default of :meth:`intercept`. Taken from the
        key folder's name (``robot-miro1`` → ``miro1``) when not given.

        ``checks``: what incoming messages are checked against (the pitch, a clock-skew
        tolerance): see :class:`~miro_ball.messages.Checks`.

        Raises :class:`ConfigError` for unusable settings (before touching the network)
        and :class:`NoServerError` when no server shows up in time.
        """
        eps = net.check_endpoints(endpoints)
        prefix = net.check_prefix(prefix)
        for name, v in (("server_timeout_s", server_timeout_s), ("query_timeout_s", query_timeout_s)):
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not (math.isfinite(v) and v > 0):
                raise ConfigError(f"{name} must be a positive number of seconds, not {v!r}")
        tls = net.check_keys_dir(keys_dir) if keys_dir is not None else None
        net.check_secured_endpoints(eps, tls)
        if robot_id is None and keys_dir is not None:
            robot_id = net.robot_id_of_keys_dir(keys_dir)
        if robot_id is not None and not is_valid_id(robot_id):
            raise ConfigError(f"robot id {robot_id!r} is not 1 to 64 characters of A-Z, a-z, 0-9, _ and -")
        settings = net.zenoh_settings(eps, tls, mode)

        try:
            import zenoh
        except ImportError as e:  # pragma: no cover - the package depends on it
            raise ConfigError(
                f"the Zenoh Python package is missing ({e}): install eclipse-zenoh==1.10.2"
            ) from None

        self = object.__new__(cls)
        self._init(eps, prefix, tls is not None, robot_id, query_timeout_s, checks)
        config = zenoh.Config()
        for key, value in settings:
            try:
                config.insert_json5(key, value)
            except Exception as e:
                raise ConfigError(f"Zenoh configuration {key}: {e}") from None
        deadline = time.monotonic() + server_timeout_s
        try:
            self._session = zenoh.open(config)
        except Exception as e:
            raise ConfigError(f"Zenoh could not open a session for {', '.join(eps)}: {e}") from None
        try:
            self._state_sub = self._session.declare_subscriber(f"{prefix}/ball/state", self._on_state_sample)
            self._server_sub = self._session.liveliness().declare_subscriber(
                f"{prefix}/servers/*", self._on_server_sample, history=True
            )
        except Exception as e:
            _close_in_background(self._session, _FAILED_CLOSE_WAIT_S)
            raise BallClientError(f"Zenoh refused the client's subscriptions: {e}") from None
        if not self._wait_for_server(deadline):
            err = self._no_server_error(server_timeout_s)
            self._closed = True
            # A link stuck half-way (a TLS handshake with a plain port) can hold a close
            # for seconds: never make the caller wait for it.
            _close_in_background(self._session, _FAILED_CLOSE_WAIT_S)
            raise err
        return self

    def _init(self, endpoints: Tuple[str, ...], prefix: str, secured: bool, robot_id: Optional[str],
              query_timeout_s: float, checks: Checks) -> None:
        self.endpoints = endpoints
        self.prefix = prefix
        self.secured = secured
        self.robot_id = robot_id
        self.query_timeout_s = float(query_timeout_s)
        self.checks = checks
        self._lock = threading.Lock()
        self._new_state = threading.Condition(self._lock)
        self._latest: Optional[BallState] = None
        self._seq = 0
        self._received = 0
        self._rejected: Dict[str, int] = {}
        self._last_rejection: Optional[str] = None
        self._callback_errors = 0
        self._callbacks: List[StateCallback] = []
        self._servers: Dict[str, None] = {}
        self._server_seen = threading.Event()
        self._answered_probe = False
        self._closed = False
        self._session: Any = None
        self._state_sub: Any = None
        self._server_sub: Any = None

    def _wait_for_server(self, deadline: float) -> bool:
        """Waits until a fusion server shows itself, at most until ``deadline``.

        A server shows itself by its liveliness token, by a ball state, or by answering a
        probe query on ``{prefix}/ball/predict`` (even with an error, such as "no ball
        estimate yet"). The probe is what finds a server through a ``zenohd`` router on a
        secured network: the access-control list lets a robot's certificate query the ball
        but not declare a liveliness subscriber, so the router never passes it the tokens.
        """
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return self._server_seen.is_set()
            if self._server_seen.wait(min(left, _PROBE_PERIOD_S)):
                return True
            left = deadline - time.monotonic()
            if left > 0 and self._probe(min(left, _PROBE_TIMEOUT_S)):
                self._answered_probe = True
                self._server_seen.set()
                return True

    def _probe(self, timeout_s: float) -> bool:
        """Whether anything answers a query on ``{prefix}/ball/predict`` within
        ``timeout_s``."""
        try:
            for reply in self._session.get(f"{self.prefix}/ball/predict?t=0", timeout=timeout_s):
                if reply.ok is not None or reply.err is not None:
                    return True
        except Exception:
            pass
        return False

    def _no_server_error(self, timeout_s: float) -> NoServerError:
        try:
            peers = len(self._session.info.peers_zid()) + len(self._session.info.routers_zid())
        except Exception:
            peers = 0
        eps = ", ".join(self.endpoints)
        head = f"no fusion server found within {timeout_s:g} s at {eps}"
        if peers == 0:
            checks = [
                "that fusion-server is running and listening there (its --listen, e.g. "
                f"`fusion-server serve --listen {self.endpoints[0]} ...`)",
                "that the host and port are right and reachable from this machine",
            ]
            if self.secured:
                checks += [
                    "that the server runs with --tls and that this key folder was made by the "
                    "same `fusion-server keys` authority as the server's",
                    "that the host in the endpoint is named in the server's certificate "
                    "(`fusion-server keys --host NAME`)",
                ]
            else:
                checks.append("that the server is not a secured one (then give keys_dir= and a tls/ endpoint)")
            msg = f"{head}: no link could be opened. Check " + "; ".join(checks) + "."
        else:
            checks = [
                f"that the server uses the key prefix {self.prefix!r} (its --prefix)",
                "that the endpoint is the fusion server's and not another program's",
            ]
            if self.secured:
                who = f"robot {self.robot_id!r}" if self.robot_id else "this key folder's robot"
                checks.insert(
                    0,
                    f"that {who} is on the server's --roster (a certificate not on it gets a "
                    "link but nothing else)",
                )
            msg = (
                f"{head}: linked to {peers} Zenoh node(s) there, but none holds a server token "
                f"{self.prefix}/servers/* or answers on {self.prefix}/ball/predict. Check "
                + "; ".join(checks) + "."
            )
        return NoServerError(msg, self.endpoints, peers)

    # ------------------------------------------------------------------ Zenoh callbacks

    def _on_server_sample(self, sample: Any) -> None:
        try:
            server = str(sample.key_expr).rsplit("/", 1)[-1]
            deleted = str(sample.kind).upper().endswith("DELETE")
            with self._lock:
                if deleted:
                    self._servers.pop(server, None)
                else:
                    self._servers[server] = None
            if not deleted:
                self._server_seen.set()
        except Exception:  # pragma: no cover - never let Zenoh's thread see an exception
            log.exception("miro_ball: could not read a server liveliness sample")

    def _on_state_sample(self, sample: Any) -> None:
        try:
            payload = sample.payload.to_bytes()
            att = sample.attachment
            server_id = None
            if att is not None:
                try:
                    server_id = att.to_string()
                except Exception:
                    server_id = None
            self.feed_state(payload, server_id=server_id)
        except Exception:  # pragma: no cover - never let Zenoh's thread see an exception
            log.exception("miro_ball: could not handle a ball state sample")

    def feed_state(self, payload: Union[bytes, str], server_id: Optional[str] = None) -> Optional[BallState]:
        """Handles one payload as if it had arrived on ``{prefix}/ball/state``: a valid
        state becomes the latest and goes to the callbacks; an invalid one is counted by
        reason (see :meth:`stats`) and skipped. Returns the state, or ``None`` when it was
        rejected. (Zenoh calls this for every sample; it is public for tests and for
        states that come another way.)"""
        now = time.time()
        try:
            state = parse_ball_state(payload, self.checks, now_s=now, server_id=server_id, received_s=now)
        except MessageError as e:
            with self._lock:
                self._received += 1
                first = e.reason not in self._rejected
                self._rejected[e.reason] = self._rejected.get(e.reason, 0) + 1
                self._last_rejection = str(e)
            (log.warning if first else log.debug)(
                "miro_ball: skipped an invalid ball state (%s)%s",
                e,
                "; further ones are counted in stats()" if first else "",
            )
            return None
        with self._lock:
            self._received += 1
            self._latest = state
            self._seq += 1
            callbacks = list(self._callbacks)
            self._new_state.notify_all()
        if server_id is not None and is_valid_id(server_id):
            self._server_seen.set()
        for cb in callbacks:
            try:
                cb(state)
            except Exception:
                with self._lock:
                    self._callback_errors += 1
                log.exception("miro_ball: an on_state callback raised (the client goes on)")
        return state

    # ------------------------------------------------------------------ the ball state

    def latest_state(self) -> Optional[BallState]:
        """The most recent valid ball state, or ``None`` before the first. Never waits.
        Check its :meth:`~BallState.age_s` and ``status``: the server stops publishing
        when it stops, and the last state stays here."""
        self._check_open()
        with self._lock:
            return self._latest

    def wait_state(self, timeout_s: float = 1.0) -> BallState:
        """Waits for the next ball state (one newer than the latest at the call) and
        returns it; raises :class:`NoStateError` if none comes within ``timeout_s``."""
        self._check_open()
        deadline = time.monotonic() + timeout_s
        with self._new_state:
            seq = self._seq
            while self._seq == seq:
                left = deadline - time.monotonic()
                if left <= 0 or self._closed:
                    break
                self._new_state.wait(left)
            if self._seq != seq and self._latest is not None:
                return self._latest
        self._check_open()
        stats = self.stats()
        servers = self.servers()
        if not servers and not self._answered_probe:
            why = "no fusion server is present any more"
        elif stats.states_received > stats.states_accepted:
            why = (f"{stats.states_received - stats.states_accepted} invalid state(s) were skipped "
                   f"(last: {stats.last_rejection})")
        else:
            who = f"server(s) {', '.join(servers)} are" if servers else "a server is"
            why = (f"{who} present; a server publishes only once it has an "
                   "estimate of the ball: are robots online and seeing it?")
        raise NoStateError(f"no ball state on {self.prefix}/ball/state within {timeout_s:g} s: {why}")

    def states(self, timeout_s: float = 1.0) -> Iterator[BallState]:
        """Yields each new ball state as it arrives (skipping any that came while the loop
        body ran), until the client is closed; raises :class:`NoStateError` when none comes
        within ``timeout_s``."""
        while not self._closed:
            try:
                yield self.wait_state(timeout_s)
            except ClientClosedError:
                return

    def on_state(self, callback: StateCallback) -> StateCallback:
        """Calls ``callback(state)`` for every valid ball state from now on, on Zenoh's
        thread. An exception in it is logged and counted, never passed on. Returns the
        callback, so this works as a decorator; :meth:`remove_callback` undoes it."""
        self._check_open()
        if not callable(callback):
            raise TypeError("on_state needs a callable taking a BallState")
        with self._lock:
            self._callbacks.append(callback)
        return callback

    def remove_callback(self, callback: StateCallback) -> None:
        """Stops calling a callback given to :meth:`on_state` (nothing if it was not)."""
        with self._lock:
            if callback in self._callbacks:
                self._callbacks.remove(callback)

    def stats(self) -> ClientStats:
        """How many states arrived, were accepted and were skipped (by reason)."""
        with self._lock:
            return ClientStats(
                states_received=self._received,
                states_accepted=self._received - sum(self._rejected.values()),
                rejected=dict(self._rejected),
                last_rejection=self._last_rejection,
                callback_errors=self._callback_errors,
            )

    def servers(self) -> List[str]:
        """Ids of the fusion servers whose liveliness token this client sees, sorted.

        Through a ``zenohd`` router on a secured network the list stays empty: the
        access-control list does not let a robot's certificate subscribe to tokens, and
        the client found the server by querying it instead."""
        with self._lock:
            return sorted(self._servers)

    # ------------------------------------------------------------------ queries

    def predict(self, t_s: float, timeout_s: Optional[float] = None) -> Prediction:
        """The ball's path predicted from the server's latest estimate, ``t_s`` seconds
        ahead (``horizon_s`` = ``t_s``). Raises :class:`QueryError` when the server refuses
        (no estimate yet, a horizon beyond its limit) and :class:`NoReplyError` when no
        server answers within ``timeout_s`` (default: the client's ``query_timeout_s``)."""
        if not isinstance(t_s, (int, float)) or isinstance(t_s, bool) or not math.isfinite(t_s) or t_s < 0:
            raise ValueError(f"t_s must be a finite number of seconds >= 0, not {t_s!r}")
        payload = self._query(f"t={_format_number(t_s)}", timeout_s)
        return parse_prediction(payload, self.checks)

    def intercept(self, robot_id: Optional[str] = None, speed_mps: Optional[float] = None,
                  timeout_s: Optional[float] = None) -> Intercept:
        """The earliest point where robot ``robot_id`` (default: this client's robot),
        from its last reported pose, can meet the ball, moving at ``speed_mps`` (default:
        the server's configured robot speed). Raises :class:`QueryError` when the server
        refuses (for example a robot it has no pose of) and :class:`NoReplyError` when no
        server answers in time."""
        if robot_id is None:
            robot_id = self.robot_id
            if robot_id is None:
                raise ValueError("which robot? pass robot_id=, or connect with robot_id= or a robot-{id} key folder")
        if not is_valid_id(robot_id):
            raise ValueError(f"robot id {robot_id!r} is not 1 to 64 characters of A-Z, a-z, 0-9, _ and -")
        params = f"robot={robot_id}"
        if speed_mps is not None:
            if (not isinstance(speed_mps, (int, float)) or isinstance(speed_mps, bool)
                    or not math.isfinite(speed_mps) or speed_mps <= 0):
                raise ValueError(f"speed_mps must be a positive number, not {speed_mps!r}")
            params += f";speed={_format_number(speed_mps)}"
        payload = self._query(params, timeout_s)
        answer = parse_intercept(payload)
        if answer.robot_id != robot_id:
            raise MessageError("robot_id", f"asked for robot {robot_id!r}, the answer is for {answer.robot_id!r}")
        return answer

    def _query(self, params: str, timeout_s: Optional[float]) -> bytes:
        """Asks ``{prefix}/ball/predict?params``; the first good reply's payload."""
        self._check_open()
        timeout = self.query_timeout_s if timeout_s is None else timeout_s
        if not isinstance(timeout, (int, float)) or not (math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"timeout_s must be a positive number of seconds, not {timeout!r}")
        selector = f"{self.prefix}/ball/predict?{params}"
        errors: List[str] = []
        try:
            replies = self._session.get(selector, timeout=float(timeout))
            for reply in replies:
                ok = reply.ok
                if ok is not None:
                    return ok.payload.to_bytes()
                err = reply.err
                if err is not None:
                    try:
                        errors.append(err.payload.to_string())
                    except Exception:
                        errors.append("(an error reply that is not text)")
        except BallClientError:
            raise
        except Exception as e:
            if self._closed:
                raise ClientClosedError("the ball client is closed") from None
            raise NoReplyError(f"query {selector} failed in Zenoh: {e}") from None
        if errors:
            raise QueryError(selector, errors[0])
        servers = self.servers()
        present = (f"server(s) {', '.join(servers)} hold a liveliness token" if servers
                   else "no server's liveliness token is visible to this client")
        raise NoReplyError(f"no reply to {selector} within {timeout:g} s ({present})")

    # ------------------------------------------------------------------ closing

    def _check_open(self) -> None:
        if self._closed:
            raise ClientClosedError("the ball client is closed")

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Leaves the network. Idempotent; waits at most a couple of seconds."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._callbacks.clear()
            self._new_state.notify_all()
        for sub in (self._state_sub, self._server_sub):
            try:
                if sub is not None:
                    sub.undeclare()
            except Exception:
                pass
        if self._session is not None:
            _close_in_background(self._session, _CLOSE_WAIT_S)

    def __enter__(self) -> "BallClient":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return (f"<BallClient {state} {', '.join(self.endpoints)} prefix={self.prefix!r}"
                f"{' secured' if self.secured else ''} robot={self.robot_id!r}>")
