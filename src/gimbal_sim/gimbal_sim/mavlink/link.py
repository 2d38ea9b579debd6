"""The MAVLink side of the gimbal nodes: pymavlink's MAVLink 2 ``common`` dialect for the
framing, and one UDP endpoint.

Framing. :class:`Codec` packs messages with the node's system and component ids and parses
each datagram on its own (a fresh parser per datagram: a truncated packet must not swallow
the start of the next datagram, as pymavlink's stream parser would). A datagram with bytes
that do not make a whole, CRC-checked packet is *malformed*: counted by the caller, and none
of its bytes acted on, not even a valid packet before the damage (a damaged datagram says
nothing reliable about its sender).

Network. :class:`UdpLink` binds ``127.0.0.1`` unless told otherwise (the project's network
rule: a MAVLink endpoint is loopback by default), replies to every address it has heard
from (mavutil's ``udpin`` behaviour, what QGroundControl and MAVProxy expect) and also sends
to the fixed ``peers`` (``udpout``: QGroundControl listens on 127.0.0.1:14550).
"""
from __future__ import annotations

import ipaddress
import math
import socket
import struct
from collections.abc import Sequence

from gimbal_kinematics.params.table import ParameterError
from pymavlink.dialects.v20 import common as mavlink

#: Largest UDP payload read at once (a MAVLink 2 packet is at most 280 bytes).
MAX_DATAGRAM = 65535
#: Addresses heard from that are kept for replies (the oldest is dropped beyond this).
MAX_HEARD = 8


class Codec:
    """Pack and parse MAVLink 2 for one (system, component) id."""

    def __init__(self, system_id: int, component_id: int) -> None:
        self.system_id, self.component_id = system_id, component_id
        self._mav = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)

    def pack(self, msg) -> bytes:
        data = msg.pack(self._mav)
        self._mav.seq = (self._mav.seq + 1) % 256
        return bytes(data)

    @staticmethod
    def parse(datagram: bytes) -> list | None:
        """The datagram's messages, or None when it holds none or any of its bytes do not
        make a whole, CRC-checked packet (module docstring)."""
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        try:
            msgs = parser.parse_buffer(bytes(datagram)) or []
        except (mavlink.MAVError, struct.error):  # a header pymavlink cannot read
            return None
        if not msgs or len(parser.buf) - parser.buf_index or any(isinstance(m, mavlink.MAVLink_bad_data)
                                                                 for m in msgs):
            return None
        return msgs


def quat_xyzw(q_wxyz: Sequence[float]) -> tuple[float, float, float, float]:
    """MAVLink's (w, x, y, z) as the project's (x, y, z, w)."""
    return (float(q_wxyz[1]), float(q_wxyz[2]), float(q_wxyz[3]), float(q_wxyz[0]))


def quat_wxyz(q_xyzw: Sequence[float]) -> list[float]:
    """The project's (x, y, z, w) as MAVLink's (w, x, y, z)."""
    return [float(q_xyzw[3]), float(q_xyzw[0]), float(q_xyzw[1]), float(q_xyzw[2])]


def unit_quaternion(q: Sequence[float], tolerance: float = 1e-3) -> tuple[float, ...] | None:
    """``q`` normalised, or None when a component is not finite or its norm is not 1 within
    ``tolerance`` (a float32 quaternion from a ground station is unit to ~1e-7)."""
    if len(q) != 4 or not all(math.isfinite(c) for c in q):
        return None
    norm = math.sqrt(sum(c * c for c in q))
    if abs(norm - 1.0) > tolerance:
        return None
    return tuple(c / norm for c in q)


def check_endpoint(host: str, port: int, name: str) -> tuple[str, int]:
    """``(host, port)`` checked: an IPv4 address and a port in 0..65535; ValueError naming
    ``name`` otherwise."""
    try:
        ipaddress.IPv4Address(host)
    except ValueError:
        raise ValueError(f"{name} must be an IPv4 address such as 127.0.0.1, got {host!r}") from None
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ValueError(f"{name} port must be within 0..65535, got {port!r}")
    return host, port


def parse_peers(peers: Sequence[str], name: str = "peers") -> list[tuple[str, int]]:
    """``["127.0.0.1:14550", ...]`` as (host, port) pairs; ValueError naming ``name``."""
    out = []
    for text in peers:
        host, sep, port = str(text).rpartition(":")
        if not sep or not port.isdigit():
            raise ValueError(f"{name} entries must be host:port, got {text!r}")
        out.append(check_endpoint(host, int(port), name))
    return out


def endpoint_values(v: dict) -> tuple[str, int, list[tuple[str, int]]]:
    """A node's ``bind_address``, ``port`` and ``peers`` checked (empty peers dropped);
    :class:`ParameterError` naming the parameter refused."""
    try:
        host, port = check_endpoint(v["bind_address"], v["port"], "bind_address")
        return host, port, parse_peers([p for p in v["peers"] if p], "peers")
    except ValueError as exc:
        raise ParameterError(f"parameter {exc}") from exc


class UdpLink:
    """A non-blocking UDP endpoint bound to ``host:port`` (port 0: any free port)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, peers: Sequence[tuple[str, int]] = ()) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind((host, port))
        except OSError:
            self.sock.close()
            raise
        self.sock.setblocking(False)
        self.address = self.sock.getsockname()
        self.peers = list(peers)
        self.heard: list[tuple[str, int]] = []
        self.send_errors = 0

    def receive(self) -> list[bytes]:
        """Every datagram waiting; remembers who sent them (for :meth:`send`)."""
        out = []
        while True:
            try:
                data, addr = self.sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # e.g. ICMP port unreachable from an earlier send: not data
                continue
            if addr not in self.heard:
                self.heard = (self.heard + [addr])[-MAX_HEARD:]
            out.append(data)

    def send(self, data: bytes) -> None:
        """``data`` to every peer and every address heard from (a refused send is counted)."""
        for addr in dict.fromkeys(self.peers + self.heard):
            try:
                self.sock.sendto(data, addr)
            except OSError:
                self.send_errors += 1

    def close(self) -> None:
        self.sock.close()


def open_link(v: dict, logger) -> UdpLink:
    """The UDP endpoint of a node's ``bind_address``, ``port`` and ``peers``, its address
    logged on ``logger`` (a warning when it is not loopback); ValueError naming the
    parameter when they cannot be used or the port is taken."""
    try:
        host, port, peers = endpoint_values(v)
    except ParameterError as exc:
        raise ValueError(str(exc)) from exc
    try:
        link = UdpLink(host, port, peers)
    except OSError as exc:
        raise ValueError(f"parameter port: cannot bind udp:{host}:{port}: {exc.strerror}") from None
    if not ipaddress.IPv4Address(host).is_loopback:
        logger.warning(f"MAVLink endpoint bound to {host}, not loopback: reachable from the network")
    logger.info(f"MAVLink on udp:{link.address[0]}:{link.address[1]}" + (f", sending to {peers}" if peers else ""))
    return link
