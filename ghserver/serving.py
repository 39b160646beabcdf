"""The HTTP layer under the Flask app: waitress, hardened so that slow or idle clients cannot lock others out
and every answer, even to a request the app never sees, is JSON.

:func:`make_server` builds a waitress server whose connections (:class:`GuardedChannel`)

* answer waitress's own refusals (body over the limit, malformed HTTP, headers too large) with a JSON error in the
  shape Hops reads (:class:`JsonErrorTask`), instead of waitress's ``text/plain`` page;
* answer a body over the limit as soon as its headers arrive, then read and discard what the client still sends
  (up to :data:`DRAIN_BYTES`, :data:`DRAIN_SECONDS`) so that it reads the answer instead of a connection reset;
* must deliver a request's headers within ``request_timeout`` seconds of its first byte, and its body at no less
  than :data:`MIN_BODY_RATE` bytes per second after that (a client trickling bytes is answered 408 and closed);
* are closed after ``channel_timeout`` seconds without a request (120 s, longer than the 100 s for which .NET
  keeps an idle connection, so Hops never reuses one the server has closed), or after ``crowded_timeout``
  seconds once more than half of ``connection_limit`` connections are open.

The connection limit (1000 by default, 500 on Windows where ``select`` takes at most 512 sockets) is far above
what Hops opens (4 connections per Rhino) and the listening socket's backlog holds clients beyond it.
"""
from __future__ import annotations

import json
import logging
import socket
import sys
import time

from waitress import create_server
from waitress.channel import HTTPChannel
from waitress.parser import HTTPRequestParser
from waitress.server import BaseWSGIServer
from waitress.task import ErrorTask
from waitress.utilities import RequestEntityTooLarge, RequestHeaderFieldsTooLarge

from ghserver.app import refusal_body

log = logging.getLogger(__name__)

DEFAULT_CONNECTION_LIMIT = 500 if sys.platform == "win32" else 1000
DEFAULT_CHANNEL_TIMEOUT = 120.0  # seconds an idle keep-alive connection stays open
DEFAULT_CROWDED_TIMEOUT = 10.0  # ... once more than half of the connection limit is in use
DEFAULT_REQUEST_TIMEOUT = 30.0  # seconds from a request's first byte to the end of its headers
MIN_BODY_RATE = 64 * 1024  # bytes per second a request body must at least arrive at
DRAIN_BYTES = 1 << 30  # bytes of a refused body read and dropped before the connection is closed
DRAIN_SECONDS = 30.0
CLEANUP_INTERVAL = 1.0  # seconds between checks of the timeouts


def _json_error(status: str, message: str) -> bytes:
    body = json.dumps(refusal_body(message)).encode("utf-8")
    head = (f"HTTP/1.1 {status}\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\n"
            "Connection: close\r\n\r\n")
    return head.encode("latin-1") + body


class JsonErrorTask(ErrorTask):
    """waitress's refusal of a request the app never sees, as a JSON error Hops can show."""

    def execute(self):
        e = self.request.error
        server = self.channel.server
        if isinstance(e, RequestEntityTooLarge):
            mb = getattr(server, "ghserver_max_body_mb", None) or (server.adj.max_request_body_size / 2**20)
            msg = f"request body is larger than the server's limit of {mb:g} MB (ghserver serve --max-body-mb)"
        elif isinstance(e, RequestHeaderFieldsTooLarge):
            msg = f"request headers are larger than the server's limit of {server.adj.max_request_header_size} bytes"
        else:
            msg = f"malformed HTTP request: {e.reason}: {str(e.body)[:200]}"
        body = json.dumps(refusal_body(msg)).encode("utf-8")
        self.status = f"{e.code} {e.reason}"
        self.response_headers.append(("Content-Type", "application/json"))
        self.set_close_on_finish()
        self.content_length = len(body)
        self.write(body)


class _Parser(HTTPRequestParser):
    """A request parser that tells its channel when a request was refused before its body was read."""

    def __init__(self, adj, channel: "GuardedChannel"):
        super().__init__(adj)
        self.channel = channel

    def received(self, data):
        n = super().received(data)
        if self.completed and self.error is not None:
            self.expect_continue = False  # refused at its headers: the client need not send the body
            self.channel.start_discarding()
            return len(data)  # the rest of this read belongs to the refused body
        return n


class GuardedChannel(HTTPChannel):
    """A waitress connection with JSON refusals, drained refused bodies and request deadlines."""

    error_task_class = JsonErrorTask
    discarding = False  # a request was refused: what the client still sends is read and dropped
    discarded = 0
    drain_deadline = 0.0
    shut_down = False  # our side of the connection is shut after the refusal was sent
    request_started = 0.0

    def parser_class(self, adj):  # called as self.parser_class(adj) by HTTPChannel.received
        self.request_started = time.time()
        return _Parser(adj, self)

    def start_discarding(self) -> None:
        if not self.discarding:
            self.discarding = True
            self.drain_deadline = time.time() + DRAIN_SECONDS

    def received(self, data):
        if self.discarding:
            self.discarded += len(data)
            if self.discarded > DRAIN_BYTES:
                self.will_close = True
            return True
        return super().received(data)

    def handle_read(self):
        if not self.discarding:
            return super().handle_read()
        try:
            data = self.recv(self.adj.recv_bytes)
        except OSError:
            self.handle_close()
            return
        if not data:  # the client is done sending: it has read the refusal
            self.handle_close()
            return
        self.last_activity = time.time()
        self.received(data)

    def readable(self):
        if self.discarding and not self.will_close:
            return True
        return super().readable()

    def writable(self):
        if self.discarding and self.shut_down:
            return self.will_close
        return super().writable()

    def handle_write(self):
        if not (self.discarding and self.close_when_flushed):
            return super().handle_write()
        if self.total_outbufs_len:
            self._flush_exception(self._flush_some_if_lockable if self.requests else self._flush_some)
        if not self.total_outbufs_len and not self.requests and not self.shut_down and not self.will_close:
            # the refusal is out: end our side, keep reading until the client closes (or the drain limits)
            try:
                self.socket.shutdown(socket.SHUT_WR)
            except OSError:
                self.will_close = True
            self.shut_down = True
        if self.will_close:
            self.handle_close()

    def refuse_slow_request(self) -> None:
        """Answer a request that arrives too slowly with a JSON 408 and close the connection."""
        with self.outbuf_lock:
            payload = _json_error("408 Request Timeout",
                                  "the request arrived too slowly and was dropped (headers must arrive within "
                                  f"{self.server.adj.ghserver_request_timeout:g} s, bodies at "
                                  f"{MIN_BODY_RATE // 1024} kB/s or more)")
            self.outbufs[-1].append(payload)
            self.current_outbuf_count += len(payload)
            self.total_outbufs_len += len(payload)
        self.request = None
        self.close_when_flushed = True

    def request_overdue(self, now: float) -> bool:
        req = self.request
        if req is None or req.completed or not self.request_started:
            return False
        allowed = self.server.adj.ghserver_request_timeout
        if req.headers_finished:
            allowed += max(req.content_length or 0, 0) / MIN_BODY_RATE
        return now - self.request_started > allowed


def _maintenance(server, now: float) -> None:
    """Close idle connections (sooner when crowded), drop requests that arrive too slowly, end finished drains."""
    adj = server.adj
    crowded = len(server._map) > adj.connection_limit // 2
    idle_cutoff = now - (adj.ghserver_crowded_timeout if crowded else adj.channel_timeout)
    for channel in list(server.active_channels.values()):
        if channel.requests:
            continue  # a request is being answered
        if isinstance(channel, GuardedChannel):
            if channel.discarding:
                if now > channel.drain_deadline:
                    channel.will_close = True
                continue
            if channel.request_overdue(now):
                channel.refuse_slow_request()
                continue
            if channel.request is not None and channel.request_started and not channel.request.completed:
                continue  # a request on its way, in time
        if channel.last_activity < idle_cutoff:
            channel.will_close = True


def _servers(server) -> list:
    if isinstance(server, BaseWSGIServer):
        return [server]
    return [d for d in server.map.values() if isinstance(d, BaseWSGIServer)]


def _raise_file_limit(needed: int) -> None:
    """Raise the soft limit of open files (POSIX) so that ``needed`` connections fit; best effort."""
    try:
        import resource
    except ImportError:  # Windows
        return
    try:
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        if soft != resource.RLIM_INFINITY and soft < needed:
            target = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
    except (ValueError, OSError) as exc:  # pragma: no cover - platform dependent
        log.warning("cannot raise the open-file limit: %s", exc)


def file_limit() -> int | None:
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
        return None if soft == resource.RLIM_INFINITY else int(soft)
    except (ImportError, ValueError, OSError):
        return None


def make_server(app, listen: str | None = None, sockets: list | None = None, *, max_body_mb: float | None = None,
                connection_limit: int = DEFAULT_CONNECTION_LIMIT, channel_timeout: float = DEFAULT_CHANNEL_TIMEOUT,
                crowded_timeout: float = DEFAULT_CROWDED_TIMEOUT, request_timeout: float = DEFAULT_REQUEST_TIMEOUT,
                **opts):
    """A hardened waitress server for ``app`` on ``listen`` (``"host:port [host:port]"``) or ``sockets``."""
    import select

    use_poll = hasattr(select, "poll")
    _raise_file_limit(connection_limit + 256)
    limit = file_limit()
    if limit is not None and connection_limit > limit - 64:
        connection_limit = max(16, limit - 64)
        log.warning("open-file limit %d: serving at most %d connections", limit, connection_limit)
    if not use_poll:
        connection_limit = min(connection_limit, 500)  # select() takes at most 512 sockets on Windows
    kw = dict(connection_limit=connection_limit, channel_timeout=int(max(1, round(channel_timeout))),
              cleanup_interval=CLEANUP_INTERVAL, asyncore_use_poll=use_poll, ident="ghserver",
              clear_untrusted_proxy_headers=True)
    if max_body_mb:
        kw["max_request_body_size"] = int(max_body_mb * 2**20) + 1
    kw.update(opts)
    server = create_server(app, sockets=sockets, **kw) if sockets else create_server(app, listen=listen, **kw)
    server.adj.ghserver_crowded_timeout = float(crowded_timeout)
    server.adj.ghserver_request_timeout = float(request_timeout)
    for srv in _servers(server):
        srv.channel_class = GuardedChannel
        srv.ghserver_max_body_mb = max_body_mb
        srv.maintenance = lambda now, srv=srv: _maintenance(srv, now)
    return server
