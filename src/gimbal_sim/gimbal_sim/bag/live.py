"""Live view: relay a run's topics, raw CDR with their ``ros2msg`` schemas, to Foxglove or
Lichtblick over the Foxglove WebSocket protocol (``gimbal-run --live``), plus the sighting
run's frames (:mod:`.live_frames`), its line of sight and target (:mod:`.live_scene`) for the 3D
panel.

In a run it lives inside the ``bag_recorder`` node: the recorder already subscribes to every
topic and holds each message's CDR bytes and stamp, so relaying them costs no second
subscription, no re-serialisation and no new participant in the lockstep pacing. Relaying only
reads those bytes: what is recorded does not depend on it. ``gimbal-bag play --live`` builds it
and hands it to the player, which gives it each message it plays (:class:`.player.PlaySink`).
Either reads the run's :class:`.scene_config.SceneConfig` beside the bag and hands it in.

The server is the Foxglove SDK's (``foxglove-sdk``), which accepts only the WebSocket
subprotocol ``foxglove.sdk.v1``. Lichtblick and older Foxglove builds (``@foxglove/ws-protocol``
0.8) offer ``foxglove.websocket.v1``, the same protocol under its older name. So the SDK server
listens on an ephemeral loopback port, and the port users connect to is a small TCP front
that renames the subprotocol in the upgrade request (to the SDK's name) and in the response
(back to the name the client offered), then splices bytes both ways untouched.
"""
from __future__ import annotations

import re
import socket
import threading
import time
from typing import Callable

from .live_frames import JSON_SCHEMA, SCHEMA_NAME, SOURCE_TOPICS as FRAME_SOURCES, TOPIC as FRAMES_TOPIC, LiveFrames
from .live_plots import SCHEMAS as PLOT_SCHEMAS, SOURCE_TOPICS as PLOT_SOURCES, LivePlots
from .live_scene import OPERATOR_ERROR, SCENE_JSON_SCHEMA, SCENE_SCHEMA_NAME, SCENE_TOPIC, LiveScene
from .scene_config import SceneConfig
from .schemas import ros2msg_schema

SDK_SUBPROTOCOL = b"foxglove.sdk.v1"
LEGACY_SUBPROTOCOL = b"foxglove.websocket.v1"
_PROTOCOL_HEADER = re.compile(rb"^(sec-websocket-protocol:[ \t]*)([^\r\n]*)", re.IGNORECASE | re.MULTILINE)
_MAX_HEADER_BYTES = 16384
#: The topics the frames and the scene are made from: a recorder with a topic list also
#: subscribes to those of them the run publishes, for the live view only (not recorded).
SOURCE_TOPICS = (*FRAME_SOURCES, OPERATOR_ERROR, *PLOT_SOURCES)


class LivePortError(OSError):
    """The live view's port cannot be bound (in use, or not allowed)."""


def parse_topic_rates(entries: list[str]) -> dict[str, float]:
    """{topic: rate_hz} from 'TOPIC=HZ' entries; raises ValueError naming the bad entry."""
    rates = {}
    for entry in entries:
        topic, sep, value = entry.partition("=")
        try:
            rate = float(value)
        except ValueError:
            rate = float("nan")
        if not sep or not topic.startswith("/") or not rate >= 0.0 or rate == float("inf"):
            raise ValueError(f"{entry!r} is not TOPIC=HZ with HZ >= 0 (0: every message)")
        rates[topic] = rate
    return rates


def _read_header(sock: socket.socket) -> tuple[bytes, bytes]:
    """(HTTP header up to and including the blank line, bytes already read after it)."""
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(4096)
        if not chunk or len(data) > _MAX_HEADER_BYTES:
            raise ConnectionError("no complete HTTP header")
        data += chunk
    end = data.index(b"\r\n\r\n") + 4
    return data[:end], data[end:]


def _offered_legacy(request: bytes) -> tuple[bytes, bool]:
    """The request with ``foxglove.websocket.v1`` offered as the SDK's name; True if it was."""
    match = _PROTOCOL_HEADER.search(request)
    if not match:
        return request, False
    offered = [p.strip() for p in match.group(2).split(b",")]
    if SDK_SUBPROTOCOL in offered or LEGACY_SUBPROTOCOL not in offered:
        return request, False
    return request[:match.start(2)] + SDK_SUBPROTOCOL + request[match.end(2):], True


#: how long the server-to-client copy lets the server's frames gather between wake-ups: the
#: SDK writes each message as its own frame, and a wake-up per frame (thousands a second) takes
#: the GIL from the recorder's callbacks that often; 10 ms is nothing to a person watching.
_GATHER_S = 0.01


def _splice(src: socket.socket, dst: socket.socket, gather_s: float = 0.0) -> None:
    try:
        while chunk := src.recv(1 << 20):
            dst.sendall(chunk)
            if gather_s:
                time.sleep(gather_s)
    except OSError:
        pass
    finally:
        for sock in (src, dst):
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass


class SubprotocolFront:
    """Loopback TCP front of a WebSocket server that also accepts ``foxglove.websocket.v1``.
    Binds at construction (a port in use raises :class:`LivePortError` naming it)."""

    def __init__(self, host: str, port: int, backend_port: int) -> None:
        self.backend = ("127.0.0.1", backend_port)
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        # Linux: lets the port be bound again while closed connections linger in TIME_WAIT; a
        # second listener on it is still refused
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((host, port))
        except OSError as exc:
            self._listener.close()
            raise LivePortError(f"cannot listen on {host}:{port} ({exc.strerror or exc}); "
                                f"is another live view running on port {port}?") from exc
        self._listener.listen(16)
        self.port = self._listener.getsockname()[1]
        self._closed = False
        threading.Thread(target=self._accept, name="live-front", daemon=True).start()

    def _accept(self) -> None:
        while not self._closed:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), name="live-conn", daemon=True).start()

    def _serve(self, client: socket.socket) -> None:
        server = None
        try:
            request, rest = _read_header(client)
            request, legacy = _offered_legacy(request)
            server = socket.create_connection(self.backend)
            server.sendall(request + rest)
            response, rest = _read_header(server)
            if legacy:
                response = _PROTOCOL_HEADER.sub(rb"\g<1>" + LEGACY_SUBPROTOCOL, response, count=1)
            client.sendall(response + rest)
        except OSError:  # ConnectionError included: a client that left mid-handshake
            for sock in (client, server):
                if sock is not None:
                    sock.close()
            return
        threading.Thread(target=_splice, args=(server, client, _GATHER_S), daemon=True).start()
        _splice(client, server)

    def close(self) -> None:
        self._closed = True
        try:  # wakes the accept() blocked in its thread; a close alone leaves the port listening
            self._listener.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        self._listener.close()


class LiveRelay:
    """Foxglove WebSocket server relaying raw CDR messages, each topic decimated to its rate."""

    def __init__(self, host: str, port: int, default_rate_hz: float, topic_rates: dict[str, float],
                 scene: SceneConfig = SceneConfig()) -> None:
        import foxglove  # only a live run needs the SDK

        self._foxglove = foxglove
        self._context = foxglove.Context()
        self._server = foxglove.start_server(name="gimbal-run", host="127.0.0.1", port=0,
                                             context=self._context, supported_encodings=["cdr"])
        try:
            self.front = SubprotocolFront(host, port, self._server.port)
        except LivePortError:
            self._server.stop()
            raise
        self.port = self.front.port
        self._default_rate = default_rate_hz
        self._rates = topic_rates
        self._channels: dict[str, object] = {}
        self._period_ns: dict[str, int] = {}
        self._next_ns: dict[str, int] = {}
        self._frame_maker = LiveFrames(scene.platform_heading_rad)
        self._scene_maker = LiveScene(scene)
        self._plot_maker = LivePlots.at_site(scene.site_lat_rad, scene.earth_rate)
        self._frames, self._scene, *plots = (
            foxglove.Channel(topic, message_encoding="json", context=self._context,
                             schema=foxglove.Schema(name=name, encoding="jsonschema", data=schema.encode()))
            for topic, name, schema in ((FRAMES_TOPIC, SCHEMA_NAME, JSON_SCHEMA),
                                        (SCENE_TOPIC, SCENE_SCHEMA_NAME, SCENE_JSON_SCHEMA),
                                        *((t, n, s) for t, (n, s) in PLOT_SCHEMAS.items())))
        self._plots = dict(zip(PLOT_SCHEMAS, plots))

    @property
    def context(self) -> object:
        """The SDK context every channel logs into: a sink added to it (e.g. ``foxglove.open_mcap``)
        gets what a connected client would."""
        return self._context

    def add_topic(self, topic: str, type_name: str) -> None:
        schema = self._foxglove.Schema(name=type_name, encoding="ros2msg",
                                       data=ros2msg_schema(type_name).encode())
        self._channels[topic] = self._foxglove.Channel(topic, schema=schema, message_encoding="cdr",
                                                       context=self._context)
        rate = self._rates.get(topic, self._default_rate)
        self._period_ns[topic] = int(round(1e9 / rate)) if rate > 0 else 0

    def publish(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Relay ``data`` unless it comes sooner than the topic's period after the last one."""
        channel = self._channels.get(topic)
        if channel is None or stamp_ns < self._next_ns.get(topic, stamp_ns):
            return
        self._next_ns[topic] = stamp_ns + self._period_ns[topic]
        if channel.has_sinks():
            channel.log(bytes(data), log_time=stamp_ns)
        if self._frames.has_sinks():
            frames = self._frame_maker.transforms(topic, bytes(data), stamp_ns)
            if frames is not None:
                self._frames.log(frames, log_time=stamp_ns)
        if self._scene.has_sinks():
            scene = self._scene_maker.update(topic, bytes(data), stamp_ns)
            if scene is not None:
                self._scene.log(scene, log_time=stamp_ns)
        # the drift's reference is the first sample: made whether or not a client is connected
        derived = self._plot_maker.update(topic, bytes(data), stamp_ns) if topic in PLOT_SOURCES else None
        if derived is not None and self._plots[derived[0]].has_sinks():
            self._plots[derived[0]].log(derived[1], log_time=stamp_ns)

    def close(self) -> None:
        self.front.close()
        self._server.stop()


class LiveGuard:
    """The live view as the recorder (or the player) calls it: a failure in it never stops
    the run. The first exception a call raises is logged once, with the error, through
    ``log`` (the node's logger), and turns the live view off: its server is closed and
    later calls do nothing. What is recorded never depended on it."""

    def __init__(self, relay: LiveRelay, log: Callable[[str], None]) -> None:
        self.relay: LiveRelay | None = relay
        self.port = relay.port
        self._log = log

    @property
    def on(self) -> bool:
        return self.relay is not None

    def add_topic(self, topic: str, type_name: str) -> None:
        if self.relay is not None:
            self._guarded(self.relay.add_topic, topic, type_name)

    def publish(self, topic: str, data: bytes, stamp_ns: int) -> None:
        relay = self.relay  # called for every message the recorder gets: one call, no more
        if relay is not None:
            try:
                relay.publish(topic, data, stamp_ns)
            except Exception as exc:  # noqa: BLE001 - any failure of the live view: off, the run goes on
                self._turn_off(topic, exc)

    def _guarded(self, call: Callable[..., None], topic: str, *args: object) -> None:
        try:
            call(topic, *args)
        except Exception as exc:  # noqa: BLE001 - any failure of the live view: off, the run goes on
            self._turn_off(topic, exc)

    def _turn_off(self, topic: str, exc: Exception) -> None:
        relay, self.relay = self.relay, None
        if relay is not None:
            closing = ""
            try:
                relay.close()
            except Exception as close_exc:  # noqa: BLE001
                closing = f"; closing it failed too: {type(close_exc).__name__}: {close_exc}"
            self._log(f"live view turned off on port {self.port} after an error on {topic}: "
                      f"{type(exc).__name__}: {exc}{closing}; the run and its recording go on")

    def close(self) -> None:
        relay, self.relay = self.relay, None
        if relay is not None:
            relay.close()
