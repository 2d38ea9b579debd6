"""CDR (XCDR1, little endian) encoding and decoding of fixed-shape ROS 2 messages, in Python.

Why: building a ``sensor_msgs/Imu`` object costs ~14 µs (every field setter checks its
type), converting and serializing it ~6 µs more, and turning received bytes back into an
object ~19 µs, against ~1 µs for one ``struct.pack`` or ``unpack_from``. The lockstep
nodes exchange about ten messages per step, so they publish and take serialized bytes
(``publish(bytes)``, ``create_subscription(..., raw=True)``) through the layouts here.

Wire format (OMG CDR, as rmw_fastrtps writes it): a 4-byte encapsulation header
``00 01 00 00`` (CDR little endian), then the fields in declaration order, each primitive
aligned to its own size counted from the end of the header; a string is a uint32 length
(including the terminating NUL), its bytes and the NUL; a sequence is a uint32 count and its
elements. Padding is written as zeros (rmw_fastrtps leaves whatever was in its buffer).

A :class:`Layout` is a ``struct.Struct`` for one message shape (the strings and sequence
lengths fixed, as they are for one publisher), built once and cached.
"""
from __future__ import annotations

import struct
from functools import lru_cache

ENCAPSULATION = b"\x00\x01\x00\x00"  # CDR_LE, no options
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<iI")
_HEADER = struct.Struct("<iII")  # stamp sec, nanosec, frame_id length
_DOUBLES: dict[int, struct.Struct] = {}


class CdrError(ValueError):
    """Bytes that are not a little-endian CDR message of the expected shape."""


class _Builder:
    """Accumulates a struct format for a body whose alignment origin is after the header."""

    def __init__(self) -> None:
        self.fmt = ["<4s"]
        self.offset = 0  # body offset

    def _align(self, n: int) -> None:
        pad = -self.offset % n
        if pad:
            self.fmt.append(f"{pad}x")
            self.offset += pad

    def prim(self, code: str, size: int, count: int = 1) -> None:
        if count == 0:
            return
        self._align(size)
        self.fmt.append(f"{count}{code}" if count > 1 else code)
        self.offset += size * count

    def string(self, text: str) -> None:
        """A string with constant content: its length and bytes are part of the format."""
        raw = text.encode() + b"\x00"
        self.prim("I", 4)
        self.fmt.append(f"{len(raw)}s")
        self.offset += len(raw)

    def struct(self) -> struct.Struct:
        return struct.Struct("".join(self.fmt))


class Layout:
    """One message shape: ``pack(*values)`` -> bytes, ``unpack(data)`` -> values, where
    ``values`` are the fields in order with the constant strings and counts left out."""

    def __init__(self, st: struct.Struct, constants: dict[int, object], total: int) -> None:
        self.struct = st
        self.size = st.size
        self._positions = [i for i in range(total) if i not in constants]
        # alternating runs of constants and of values: pack() is a few tuple concatenations
        self._segments: list[tuple[bool, object]] = []
        i = v = 0
        while i < total:
            if i in constants:
                run = []
                while i < total and i in constants:
                    run.append(constants[i])
                    i += 1
                self._segments.append((True, tuple(run)))
            else:
                start = v
                while i < total and i not in constants:
                    i += 1
                    v += 1
                self._segments.append((False, slice(start, v)))

    def pack(self, *values: float) -> bytes:
        args: tuple = ()
        for const, seg in self._segments:
            args += seg if const else values[seg]
        return self.struct.pack(*args)

    def unpack(self, data: bytes) -> tuple:
        if len(data) != self.size or data[:4] != ENCAPSULATION:
            raise CdrError(f"expected {self.size} bytes of little-endian CDR, got {len(data)}")
        fields = self.struct.unpack(data)
        return tuple(fields[p] for p in self._positions)


def _layout(build) -> Layout:
    """Build a layout; ``build(b, const)`` declares the fields, calling ``const(value)`` right
    after declaring a field whose value is constant."""
    b = _Builder()
    constants: dict[int, object] = {0: ENCAPSULATION}
    count = [1]  # struct items declared so far

    def field(code: str, size: int, n: int = 1, value=None):
        b.prim(code, size, n)
        if value is not None:
            constants[count[0]] = value
        count[0] += n

    def string(text: str):
        raw = text.encode() + b"\x00"
        b.string(text)
        constants[count[0]] = len(raw)
        constants[count[0] + 1] = raw
        count[0] += 2

    build(field, string)
    return Layout(b.struct(), constants, count[0])


@lru_cache(maxsize=None)
def imu_layout(frame_id: str) -> Layout:
    """sensor_msgs/Imu: values = sec, nanosec, orientation (4), its covariance (9),
    angular_velocity (3), covariance (9), linear_acceleration (3), covariance (9)."""
    def build(field, string):
        field("i", 4)
        field("I", 4)
        string(frame_id)
        field("d", 8, 4 + 9 + 3 + 9 + 3 + 9)
    return _layout(build)


@lru_cache(maxsize=None)
def vector3_stamped_layout(frame_id: str) -> Layout:
    """geometry_msgs/Vector3Stamped: values = sec, nanosec, x, y, z."""
    def build(field, string):
        field("i", 4)
        field("I", 4)
        string(frame_id)
        field("d", 8, 3)
    return _layout(build)


@lru_cache(maxsize=None)
def navsat_fix_layout(frame_id: str) -> Layout:
    """sensor_msgs/NavSatFix: values = sec, nanosec, status (int8), service (uint16),
    latitude, longitude, altitude, position_covariance (9), position_covariance_type (uint8)."""
    def build(field, string):
        field("i", 4)
        field("I", 4)
        string(frame_id)
        field("b", 1)
        field("H", 2)
        field("d", 8, 3 + 9)
        field("B", 1)
    return _layout(build)


@lru_cache(maxsize=None)
def odometry_layout(frame_id: str, child_frame_id: str) -> Layout:
    """nav_msgs/Odometry: values = sec, nanosec, position (3), orientation (4), pose
    covariance (36), linear (3), angular (3), twist covariance (36)."""
    def build(field, string):
        field("i", 4)
        field("I", 4)
        string(frame_id)
        string(child_frame_id)
        field("d", 8, 3 + 4 + 36 + 3 + 3 + 36)
    return _layout(build)


@lru_cache(maxsize=None)
def clock_layout() -> Layout:
    """rosgraph_msgs/Clock: values = sec, nanosec."""
    def build(field, string):
        field("i", 4)
        field("I", 4)
    return _layout(build)


@lru_cache(maxsize=None)
def joint_state_layout(frame_id: str, names: tuple[str, ...], n_position: int, n_velocity: int,
                       n_effort: int) -> Layout:
    """sensor_msgs/JointState with these names and array lengths: values = sec, nanosec,
    position (n_position), velocity (n_velocity), effort (n_effort)."""
    def build(field, string):
        field("i", 4)
        field("I", 4)
        string(frame_id)
        field("I", 4, value=len(names))
        for name in names:
            string(name)
        for n in (n_position, n_velocity, n_effort):
            field("I", 4, value=n)
            field("d", 8, n)
    return _layout(build)


class _Reader:
    """Sequential reader of a CDR body (for shapes not known in advance)."""

    __slots__ = ("data", "pos")

    def __init__(self, data: bytes) -> None:
        if len(data) < 4 or data[:2] != b"\x00\x01":
            raise CdrError("not little-endian CDR (encapsulation header)")
        self.data = data
        self.pos = 4

    def _align(self, n: int) -> None:
        self.pos += -(self.pos - 4) % n

    def u32(self) -> int:
        self._align(4)
        (v,) = _U32.unpack_from(self.data, self.pos)
        self.pos += 4
        return v

    def time_ns(self) -> int:
        self._align(4)
        sec, nsec = _TIME.unpack_from(self.data, self.pos)
        self.pos += 8
        return sec * 1_000_000_000 + nsec

    def string(self) -> str:
        n = self.u32()
        raw = self.data[self.pos:self.pos + n]
        if n == 0 or len(raw) != n or raw[-1] != 0:
            raise CdrError("malformed CDR string")
        self.pos += n
        return raw[:-1].decode()

    def doubles(self, n: int) -> tuple[float, ...]:
        if n == 0:
            return ()
        self._align(8)
        values = struct.unpack_from(f"<{n}d", self.data, self.pos)
        self.pos += 8 * n
        return values

    def double_seq(self) -> tuple[float, ...]:
        return self.doubles(self.u32())


def read_header(data: bytes) -> tuple[int, str, "_Reader"]:
    """(stamp [ns], frame_id, reader positioned after the header) of a message that starts
    with a std_msgs/Header."""
    try:
        r = _Reader(data)
        return r.time_ns(), r.string(), r
    except (struct.error, UnicodeDecodeError) as exc:
        raise CdrError(f"malformed CDR header: {exc}") from exc


def read_stamp(data: bytes) -> int:
    """The leading builtin_interfaces/Time of a message (a Header's stamp, or a Clock) [ns]."""
    if len(data) < 12 or data[:2] != b"\x00\x01":
        raise CdrError("not little-endian CDR with a leading stamp")
    sec, nsec = _TIME.unpack_from(data, 4)
    return sec * 1_000_000_000 + nsec


def read_header_doubles(data: bytes, n: int) -> tuple[int, str, tuple[float, ...]]:
    """(stamp [ns], frame_id, the n float64 that follow) of a message made of a
    std_msgs/Header and n doubles (Imu: 37, Vector3Stamped: 3): three struct calls."""
    try:
        sec, nsec, length = _HEADER.unpack_from(data, 4)
        end = 16 + length  # the string's bytes start at 16 (4 encapsulation + 12)
        if data[:2] != b"\x00\x01" or length == 0 or data[end - 1] != 0:
            raise CdrError("not a little-endian CDR message with a std_msgs/Header")
        st = _DOUBLES.get(n)
        if st is None:
            st = _DOUBLES[n] = struct.Struct(f"<{n}d")
        values = st.unpack_from(data, 4 + ((end - 4 + 7) & ~7))
        return sec * 1_000_000_000 + nsec, data[16:end - 1].decode(), values
    except (struct.error, IndexError, UnicodeDecodeError) as exc:
        raise CdrError(f"malformed or truncated CDR message: {exc}") from exc


# JointState: the bytes from the frame id's length to the end of the names are the same in
# every message of one publisher, so a message whose prefix matches one seen before is
# read with one struct call on its three sequences.
_JS_SHAPES: list[tuple[bytes, tuple[str, ...], struct.Struct, tuple[int, int, int]]] = []
_JS_SHAPES_MAX = 16


def _seq_tail(offset: int, counts: tuple[int, int, int]) -> struct.Struct:
    """Struct for three (uint32 count, float64[count]) sequences starting at absolute offset."""
    fmt, pos = ["<"], offset - 4  # body offset
    for n in counts:
        pad = -pos % 4
        fmt.append(f"{pad}xI" if pad else "I")
        pos += pad + 4
        if n:
            pad = -pos % 8
            fmt.append(f"{pad}x{n}d" if pad else f"{n}d")
            pos += pad + 8 * n
    return struct.Struct("".join(fmt))


def read_joint_state(data: bytes) -> tuple[int, str, tuple[str, ...], tuple[float, ...], tuple[float, ...],
                                            tuple[float, ...]]:
    """(stamp [ns], frame_id, names, position, velocity, effort) of a sensor_msgs/JointState."""
    for prefix, names, tail, counts in _JS_SHAPES:
        if data.startswith(prefix, 12):
            try:
                v = tail.unpack_from(data, 12 + len(prefix))
            except struct.error:
                continue
            n0, n1, n2 = counts
            if (v[0], v[1 + n0], v[2 + n0 + n1]) == counts and data[:2] == b"\x00\x01":
                sec, nsec = _TIME.unpack_from(data, 4)
                return (sec * 1_000_000_000 + nsec, data[16:16 + _U32.unpack_from(data, 12)[0] - 1].decode(),
                        names, v[1:1 + n0], v[2 + n0:2 + n0 + n1], v[3 + n0 + n1:])
    stamp, frame, r = read_header(data)
    try:
        names = tuple(r.string() for _ in range(r.u32()))
        names_end = r.pos
        seqs = (r.double_seq(), r.double_seq(), r.double_seq())
    except (struct.error, UnicodeDecodeError) as exc:
        raise CdrError(f"malformed JointState: {exc}") from exc
    if len(_JS_SHAPES) < _JS_SHAPES_MAX:
        counts = (len(seqs[0]), len(seqs[1]), len(seqs[2]))
        _JS_SHAPES.append((data[12:names_end], names, _seq_tail(names_end, counts), counts))
    return (stamp, frame, names) + seqs
