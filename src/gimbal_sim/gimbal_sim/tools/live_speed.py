"""``gimbal-bench live``: the lockstep speed of a run without and with the live view, one
client connected and subscribed to every channel, and whether both bags hold the same data.

The client here is a minimal Foxglove WebSocket client (RFC 6455 framing, the protocol's
``advertise`` / ``subscribe``): it only loads the server as a viewer would. The protocol's
conformance is checked against an independent client in test/test_live_view.py.
"""
from __future__ import annotations

import json
import os
import socket
import struct
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from ..bag.compare import compare_bags
from ..graph.orchestrator import run
from ..graph.scenario import Scenario

_HANDSHAKE = ("GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
              "Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
              "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n")


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ConnectionError("closed")
        data += chunk
    return data


def _send_text(sock: socket.socket, text: str) -> None:
    payload, mask = text.encode(), os.urandom(4)
    size = len(payload)
    head = bytes([0x81]) + (bytes([0x80 | size]) if size < 126 else bytes([0x80 | 126]) + struct.pack(">H", size)
                            if size < 65536 else bytes([0x80 | 127]) + struct.pack(">Q", size))
    sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


@dataclass
class ViewerClient:
    """Connects to ``port`` when it opens, subscribes to every advertised channel and counts
    the messages it receives until the server closes."""
    port: int
    messages: int = 0
    connected: bool = False

    def start(self) -> threading.Thread:
        thread = threading.Thread(target=self._run, daemon=True)
        thread.start()
        return thread

    def _connect(self, timeout_s: float = 120.0) -> socket.socket:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                return socket.create_connection(("127.0.0.1", self.port), timeout=1.0)
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)

    def _run(self) -> None:
        try:
            sock = self._connect()
            sock.settimeout(None)
            sock.sendall(_HANDSHAKE.format(port=self.port, key="dGhlIHNhbXBsZSBub25jZQ==").encode())
            header = b""
            while b"\r\n\r\n" not in header:
                header += _recv_exact(sock, 1)
            self.connected = header.startswith(b"HTTP/1.1 101")
            next_id = 0
            while self.connected:
                b0, b1 = _recv_exact(sock, 2)
                size = b1 & 0x7F
                if size == 126:
                    size = struct.unpack(">H", _recv_exact(sock, 2))[0]
                elif size == 127:
                    size = struct.unpack(">Q", _recv_exact(sock, 8))[0]
                payload = _recv_exact(sock, size)
                opcode = b0 & 0x0F
                if opcode == 1 and json.loads(payload).get("op") == "advertise":
                    channels = json.loads(payload)["channels"]
                    subs = [{"id": next_id + i, "channelId": ch["id"]} for i, ch in enumerate(channels)]
                    next_id += len(subs)
                    _send_text(sock, json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif opcode == 2:
                    self.messages += 1
                elif opcode == 8:
                    break
        except (OSError, ValueError):
            pass


def _timed_run(scenario: Scenario, out: Path, mode: str, **kwargs) -> tuple[float, float]:
    """(steps/s, CPU seconds the run's node processes spent after the first step) of one
    run into ``out``; their start-up (imports, discovery) is the same with and without."""
    result = run(scenario, out, mode, progress=False, **kwargs)
    cpu = sum(stats.cpu_s - result.cpu_at_start.get(name, 0.0) for name, stats in result.processes.items())
    return result.sim_s * scenario.sim_rate_hz / result.wall_s, cpu


def measure_live(scenario: Scenario, work: Path, port: int, mode: str = "processes") -> dict:
    """Runs ``scenario`` twice into ``work``: plain, then with the live view and one client.

    Besides the steps/s it returns the CPU seconds the run's node processes used: on a shared
    machine the wall time of one pair varies by more than the relay costs, the CPU the relay
    adds to the run much less. In processes mode the client's own work (in this process) is
    not counted, as a viewer runs elsewhere; in container mode it is."""
    steps_plain, cpu_plain = _timed_run(scenario, work / "plain", mode)
    client = ViewerClient(port)
    thread = client.start()
    steps_live, cpu_live = _timed_run(scenario, work / "live", mode,
                                      live={"live_port": port, "live_rate_hz": 50.0, "live_topic_rates": []})
    thread.join(timeout=10.0)
    same = compare_bags(work / "plain", work / "live")
    return {
        "steps_per_s_plain": steps_plain, "steps_per_s_live": steps_live,
        "cpu_s_plain": cpu_plain, "cpu_s_live": cpu_live,
        "client_connected": client.connected, "client_messages": client.messages,
        "same_data": same.identical, "byte_identical": same.byte_identical,
    }
