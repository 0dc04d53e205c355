"""The exceptions of :mod:`miro_ball`.

Every exception the client raises on purpose derives from :class:`BallClientError`, so a
behaviour program can catch them all with one ``except``. Each also derives from the
built-in exception a Python programmer would expect (``ValueError``, ``ConnectionError``,
``TimeoutError``), so code that already catches those keeps working.
"""

from __future__ import annotations


class BallClientError(Exception):
    """Base class of every error raised by the ball client."""


class ConfigError(BallClientError, ValueError):
    """The client was given settings it cannot use: a malformed endpoint, a missing or
    unreadable key file, TLS endpoints without keys (or keys with plain endpoints), an
    invalid prefix, robot id or timeout. Raised before anything is sent on the network."""


class NoServerError(BallClientError, ConnectionError):
    """No fusion server was found on the network within the connection timeout.

    The message names the endpoints and says what to check. ``endpoints`` and
    ``linked_peers`` (how many Zenoh nodes the client did reach) are kept as attributes.
    """

    def __init__(self, message: str, endpoints: tuple = (), linked_peers: int = 0):
        super().__init__(message)
        self.endpoints = tuple(endpoints)
        self.linked_peers = linked_peers


class MessageError(BallClientError, ValueError):
    """A payload is not a valid message of the wire protocol.

    ``reason`` is a short stable label, the same as the protocol's rejection reasons
    where one applies (``version``, ``non_finite``, ``covariance_not_pd``, ...), plus
    ``not_json``, ``no_version`` and ``bad_path`` (a prediction whose samples are missing
    or out of time order).
    """

    def __init__(self, reason: str, detail: str):
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail


class QueryError(BallClientError):
    """The fusion server answered a query with an error (for example a robot it has no pose
    of, or no ball estimate yet). ``server_message`` is the server's own explanation and
    ``selector`` the query that was asked."""

    def __init__(self, selector: str, server_message: str):
        super().__init__(f"the fusion server refused {selector}: {server_message}")
        self.selector = selector
        self.server_message = server_message


class NoReplyError(BallClientError, TimeoutError):
    """A query got no reply at all within its timeout (no server answering, or the link
    went down)."""


class NoStateError(BallClientError, TimeoutError):
    """No new ball state arrived within the time :meth:`BallClient.wait_state` waited."""


class ClientClosedError(BallClientError, RuntimeError):
    """The client was used after :meth:`BallClient.close`."""

