"""``gimbal-bench live``: the lockstep speed of a run without and with the live view, one
client connected and subscribed to every channel, and whether both bags hold the same data;
over alternating pairs of runs, each pair's figures and the medians.

The client here is a minimal Foxglove WebSocket client (RFC 6455 framing, the protocol's
``advertise`` / ``subscribe``): it only loads the server as a viewer would. The protocol's
conformance is checked against an independent client in test/test_live_view.py.
"""
from __future__ import annotations

import json
import os
import shutil
import socket
import struct
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from statistics import median

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
    run into ``out``. The steps/s are the stepping's alone: the steps between the first and
    the last /clock the orchestrator's monitor saw, over the wall time between their
    arrivals; the processes' start-up (imports, discovery) and shutdown are left out."""
    result = run(scenario, out, mode, progress=False, **kwargs)
    if result.interrupted:
        raise KeyboardInterrupt("stopped the benchmark in a run")
    stamps, walls = result.clock_stamp, result.clock_wall
    if len(stamps) < 2 or walls[-1] <= walls[0]:
        raise RuntimeError(f"{out}: fewer than two /clock messages seen; no stepping to time")
    steps = round((stamps[-1] - stamps[0]) * scenario.sim_rate_hz / 1e9)
    cpu = sum(stats.cpu_s - result.cpu_at_start.get(name, 0.0) for name, stats in result.processes.items())
    return steps / (walls[-1] - walls[0]), cpu


def _pair(scenario: Scenario, work: Path, port: int, mode: str, live_first: bool) -> dict:
    """One run without and one with the live view and a client, in that order or reversed."""
    runs = {}
    client = ViewerClient(port)
    for kind in (("live", "plain") if live_first else ("plain", "live")):
        if kind == "plain":
            runs[kind] = _timed_run(scenario, work / "plain", mode)
            continue
        thread = client.start()
        runs[kind] = _timed_run(scenario, work / "live", mode,
                                live={"live_port": port, "live_rate_hz": 50.0, "live_topic_rates": []})
        thread.join(timeout=10.0)
    same = compare_bags(work / "plain", work / "live")
    (steps_plain, cpu_plain), (steps_live, cpu_live) = runs["plain"], runs["live"]
    return {"order": "live, plain" if live_first else "plain, live",
            "steps_per_s_plain": steps_plain, "steps_per_s_live": steps_live,
            "slowdown": steps_plain / steps_live - 1.0, "cpu_s_plain": cpu_plain, "cpu_s_live": cpu_live,
            "cpu_change": cpu_live / cpu_plain - 1.0, "client_connected": client.connected,
            "client_messages": client.messages, "same_data": same.identical, "byte_identical": same.byte_identical,
            "load": os.getloadavg()[0]}


def measure_live(scenario: Scenario, work: Path, port: int, mode: str = "processes", pairs: int = 3) -> dict:
    """``pairs`` pairs of runs of ``scenario`` in ``work``, each one plain and one with the
    live view and one client, the order alternating (plain first in the first pair) so that
    a machine's drift in speed does not favour one side; each pair's bags compared.

    Besides the steps/s it returns the CPU seconds the run's node processes used: on a shared
    machine the wall time of one pair varies by more than the relay costs, the CPU the relay
    adds to the run much less. In processes mode the client's own work (in this process) is
    not counted, as a viewer runs elsewhere; in container mode it is. The medians over the
    pairs are the figures to quote."""
    results = []
    for i in range(pairs):
        pair_dir = work / f"pair{i + 1}"
        results.append(_pair(scenario, pair_dir, port, mode, live_first=i % 2 == 1))
        shutil.rmtree(pair_dir, ignore_errors=True)
    return {"pairs": results, "median_slowdown": median(r["slowdown"] for r in results),
            "median_cpu_change": median(r["cpu_change"] for r in results),
            "same_data": all(r["same_data"] for r in results),
            "client_connected": all(r["client_connected"] for r in results)}


def live_report(title: str, r: dict) -> str:
    """The text ``gimbal-bench live`` prints for :func:`measure_live`'s result ``r``."""
    n = len(r["pairs"])
    lines = [f"{title}, {n} pair{'s' if n != 1 else ''} of runs (load: the 1-min load average after each pair):",
             "  steps/s: steps from the first to the last /clock over their wall time (start-up excluded);",
             "  CPU s: the run's node processes after the first step",
             f"  {'pair':<5}{'order':<13}{'steps/s without':>16}{'with --live':>12}{'slowdown':>10}"
             f"{'CPU s without':>15}{'with':>8}{'CPU':>9}{'client msgs':>13}{'load':>7}  bags"]
    for i, p in enumerate(r["pairs"], 1):
        bags = ("same data" + (" (byte-identical)" if p["byte_identical"] else "")) if p["same_data"] \
            else "DIFFERENT data"
        msgs = f"{p['client_messages']}" if p["client_connected"] else "NOT conn."
        lines.append(f"  {i:<5}{p['order']:<13}{p['steps_per_s_plain']:>16,.0f}{p['steps_per_s_live']:>12,.0f}"
                     f"{p['slowdown']:>+10.1%}{p['cpu_s_plain']:>15.2f}{p['cpu_s_live']:>8.2f}"
                     f"{p['cpu_change']:>+9.1%}{msgs:>13}{p['load']:>7.2f}  {bags}")
    lines += [f"  median slowdown {r['median_slowdown']:+.1%} (target <= +10%), "
              f"median CPU change {r['median_cpu_change']:+.1%}",
              f"  client: connected in {sum(p['client_connected'] for p in r['pairs'])} of {n} pairs",
              f"  bags: {'same data' if r['same_data'] else 'DIFFERENT data'} in "
              f"{sum(p['same_data'] for p in r['pairs'])} of {n} pairs"]
    return "\n".join(lines)
