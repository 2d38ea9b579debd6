"""Recording a block of engine steps at once: each node's serialisation as byte templates.

A node's serialisation function (``nodes.wire``, ``gimbal_estimators.wire``,
``gimbal_control.wire``) stays the one definition of its messages. A :class:`BlockSource`
wraps one call of it, ``fn(t_ns, row) -> [(topic, type, bytes)]`` with ``row`` one step's
record row, and derives from the function itself where each message's per-step values sit:
it serialises a row of distinct sentinel values and finds each column's float64 bytes and the
stamp's (sec, nanosec) in the output. Every message of these fixed-layout types (fixed frame
ids and joint names, fixed array lengths) is then its bytes with those fields overwritten,
which numpy does for a whole block at once. The derivation is checked on more rows (random
values of both signs, another stamp) against the function; a message it does not reproduce
(a value the function transforms, e.g. Euler angles to a quaternion) is serialised by the
function, row by row. ``fn`` must not branch on the row's values: a node whose messages
depend on a flag is several sources, each given the steps it applies to.

:class:`BlockRecorder` writes a block: the steps each source applies to, the scenario's
``record`` list and record rates (:class:`.recording.EngineBag`), the messages in the
stages' order (by stamp, then source, then the function's order), laid out as MCAP Message
records by :func:`_lay_out` and handed to :meth:`..bag.writer.BagWriter.write_records`.
"""
from __future__ import annotations

import struct
from typing import Callable

import numpy as np
from numba import njit

from .recording import EngineBag

Messages = list[tuple[str, str, bytes]]
#: (sec, nanosec) of a std_msgs/Header stamp
_STAMP = struct.Struct("<iI")
_F64 = struct.Struct("<d")
_HEAD = 31  # an MCAP Message record's opcode, length, channel, sequence, log and publish time
_CHECKS = 4


def _find_all(data: bytes, pattern: bytes) -> list[int]:
    found, i = [], data.find(pattern)
    while i >= 0:
        found.append(i)
        i = data.find(pattern, i + 1)
    return found


class Template:
    """One message's bytes with the stamp and the row's columns at fixed offsets."""

    def __init__(self, data: bytes, stamp_at: list[int], fields: list[tuple[int, int]]) -> None:
        self.size = len(data)
        self.data = np.frombuffer(data, dtype=np.uint8)
        names = [f"s{i}" for i in range(len(stamp_at))] + [f"n{i}" for i in range(len(stamp_at))] + \
            [f"f{i}" for i in range(len(fields))]
        self.dtype = np.dtype({"names": names, "formats": ["<i4"] * len(stamp_at) + ["<u4"] * len(stamp_at) +
                               ["<f8"] * len(fields),
                               "offsets": stamp_at + [o + 4 for o in stamp_at] + [o for o, _ in fields],
                               "itemsize": self.size})
        self.n_stamps, self.columns = len(stamp_at), [c for _, c in fields]

    def fill(self, stamps: np.ndarray, column: Callable[[int], np.ndarray], raw: np.ndarray) -> np.ndarray:
        """The messages at ``stamps`` [ns], ``column(c)`` their values of column c, into
        ``raw`` ((m, size) bytes)."""
        out = raw.reshape(-1).view(self.dtype)
        raw[:] = self.data
        sec, nsec = np.divmod(stamps, 1_000_000_000)
        for i in range(self.n_stamps):
            out[f"s{i}"], out[f"n{i}"] = sec, nsec
        for i, c in enumerate(self.columns):
            out[f"f{i}"] = column(c)
        return raw

    @staticmethod
    def derive(data: bytes, t_ns: int, row: np.ndarray) -> Template | None:
        """The template of ``data``, serialised at ``t_ns`` from the sentinel ``row``; None
        when the stamp is not in it."""
        stamp_at = _find_all(data, _STAMP.pack(t_ns // 1_000_000_000, t_ns % 1_000_000_000))
        if not stamp_at:
            return None
        fields = [(o, c) for c, v in enumerate(row.tolist()) for o in _find_all(data, _F64.pack(v))]
        return Template(data, stamp_at, fields)


class BlockSource:
    """One serialisation call of a node, ``fn(t_ns, row)``, as templates (module docstring);
    ``n_columns``: the row's length; ``extra(row)``: values ``fn`` computes from the row
    (e.g. a quaternion from Euler angles), by the same scalar code, as more columns."""

    def __init__(self, node: str, fn: Callable[[int, np.ndarray], Messages], n_columns: int,
                 extra: Callable[[np.ndarray], tuple] | None = None) -> None:
        self.node, self.fn, self.n_columns, self.extra = node, fn, n_columns, extra
        rng = np.random.default_rng(20260901)
        row = rng.uniform(1.0, 2.0, n_columns) * np.exp2(rng.integers(-20, 20, n_columns))
        t_ns = 1_734_567 * 1_000_000_000 + 987_654_321
        messages = fn(t_ns, row)
        self.messages = [(topic, type_name) for topic, type_name, _ in messages]
        self.sizes = [len(data) for _, _, data in messages]
        full = row if extra is None else np.concatenate([row, np.asarray(extra(row), dtype=float)])
        self.templates = [Template.derive(data, t_ns, full) for _, _, data in messages]
        for j in range(_CHECKS):
            t = t_ns + 1_000_003_331 * (j + 1)
            rows = (rng.normal(size=n_columns) * 10.0 ** rng.integers(-6, 6, n_columns))[None, :]
            column = self.columns(rows, np.array([0]))
            for i, (_, _, data) in enumerate(fn(t, rows[0])):
                tpl = self.templates[i]
                if tpl is not None and tpl.fill(np.array([t]), column, np.empty((1, tpl.size), np.uint8)).tobytes() \
                        != data:
                    self.templates[i] = None

    def columns(self, rows: np.ndarray, index: np.ndarray) -> Callable[[int], np.ndarray]:
        """``column(c)``: column c of the rows ``index`` (past the row: :attr:`extra`'s)."""
        if self.extra is None:
            return lambda c: rows[index, c]
        ext = np.array([self.extra(rows[k]) for k in index.tolist()], dtype=float).reshape(len(index), -1)
        return lambda c: rows[index, c] if c < self.n_columns else ext[:, c - self.n_columns]

    def payloads(self, i: int, stamps: np.ndarray, rows: np.ndarray, index: np.ndarray,
                 column: Callable[[int], np.ndarray], raw: np.ndarray) -> None:
        """Message ``i`` of the steps ``index`` into ``raw`` ((m, size) bytes; ``column``:
        :meth:`columns`)."""
        tpl = self.templates[i]
        if tpl is not None:
            tpl.fill(stamps[index], column, raw)
            return
        data = b"".join(self.fn(int(stamps[k]), rows[k])[i][2] for k in index.tolist())
        raw[:] = np.frombuffer(data, dtype=np.uint8).reshape(raw.shape)


class BlockRecorder:
    """``recorder(stamps, rows, masks)``: record a block of steps (module docstring): each
    source's messages at the steps its mask (bool array, or None: every step) selects."""

    def __init__(self, bag: EngineBag, sources: list[BlockSource]) -> None:
        self.bag, self.sources = bag, sources
        #: (source, message index, topic name) of each recorded message of a step, in order
        self.parts = [(s, i, name) for s in sources for i, (topic, _) in enumerate(s.messages)
                      if (name := bag.topic_name(s.node, topic)) is not None]
        self.topics = list(dict.fromkeys(name for _, _, name in self.parts))

    def __call__(self, stamps: np.ndarray, rows: np.ndarray, masks: list[np.ndarray | None]) -> None:
        steps = {id(s): np.arange(len(stamps)) if m is None else np.flatnonzero(m)
                 for s, m in zip(self.sources, masks)}
        index = [steps[id(s)] for s, _, _ in self.parts]
        self._apply_rates(stamps, index)
        for (s, i, name), idx in zip(self.parts, index):
            if len(idx):  # registered at its first message, as the recorder does
                self.bag.add_topic(name, s.messages[i][1])
        sizes = np.array([s.sizes[i] for s, i, _ in self.parts], dtype=np.int64)
        base = np.concatenate([[0], np.cumsum([len(idx) for idx in index] * sizes)])
        flat, columns = self._buffer("_flat", int(base[-1])), {}
        for p, ((s, i, _), idx) in enumerate(zip(self.parts, index)):
            key = (id(s), id(idx))  # a source's messages share its steps' array unless a rate cut it
            if key not in columns:
                columns = {key: s.columns(rows, idx)}
            s.payloads(i, stamps, rows, idx, columns[key], flat[base[p]:base[p + 1]].reshape(len(idx), sizes[p]))
        part_of = np.concatenate([np.full(len(idx), p, dtype=np.int64) for p, idx in enumerate(index)])
        log = np.concatenate([stamps[idx] for idx in index]).astype(np.int64)
        order = np.lexsort((part_of, log))
        part_of, log = part_of[order], log[order]
        row_of = np.concatenate([np.arange(len(idx), dtype=np.int64) for idx in index])[order]
        writer = self.bag.writer
        topic_of_part = np.array([self.topics.index(name) for _, _, name in self.parts], dtype=np.int64)
        channel = np.array([writer.topics[name].channel_id if name in writer.topics else 0
                            for _, _, name in self.parts], dtype=np.int64)
        seq = np.array([writer.sequence(t) if t in writer.topics else 0 for t in self.topics], dtype=np.int64)
        size = int(base[-1]) + _HEAD * len(log)
        out, starts = self._buffer("_out", size), np.empty(len(log), dtype=np.int64)
        _lay_out(flat, base, sizes, part_of, row_of, log, channel, topic_of_part, seq, out, starts)
        if len(log):
            writer.write_records(out, starts, log, self.topics, topic_of_part[part_of])

    def _buffer(self, name: str, size: int) -> np.ndarray:
        """``size`` bytes of a buffer kept from block to block (fresh pages cost more than
        filling them)."""
        buf = getattr(self, name, None)
        if buf is None or len(buf) < size:
            buf = np.empty(size, dtype=np.uint8)
            setattr(self, name, buf)
        return buf[:size]

    def _apply_rates(self, stamps: np.ndarray, index: list[np.ndarray]) -> None:
        """Drop from ``index`` the messages the topics' record rates leave out."""
        rates = self.bag.rates
        for name in self.topics:
            if not rates or name not in rates.period_ns:
                continue
            mine = [p for p, (_, _, n) in enumerate(self.parts) if n == name]
            st = np.concatenate([stamps[index[p]] for p in mine])
            who = np.concatenate([np.full(len(index[p]), p) for p in mine])
            order = np.lexsort((who, st))
            keep = np.zeros(len(st), dtype=bool)
            keep[order] = rates.keep_sorted(name, st[order])
            for p in mine:
                index[p], keep = index[p][keep[:len(index[p])]], keep[len(index[p]):]


@njit(cache=True)
def _lay_out(flat, base, sizes, part_of, row_of, log, channel, topic_of_part, seq, out, starts):  # pragma: no cover - numba
    """The MCAP Message records (opcode 0x05, length, channel, sequence, log and publish time,
    payload: message ``row_of[i]`` of part ``part_of[i]`` in ``flat``, the part's from ``base``,
    ``sizes`` bytes each) of the messages in order, back to back in ``out``; ``starts``: where
    each begins; ``seq``: each topic's next sequence number (advanced)."""
    at = 0
    for i in range(part_of.size):
        p = part_of[i]
        n = sizes[p]
        t = topic_of_part[p]
        starts[i] = at
        out[at] = 5
        length, ch, sq, lt = 22 + n, channel[p], seq[t], log[i]
        seq[t] += 1
        for b in range(8):
            out[at + 1 + b] = (length >> (8 * b)) & 0xFF
            out[at + 15 + b] = (lt >> (8 * b)) & 0xFF
            out[at + 23 + b] = (lt >> (8 * b)) & 0xFF
        for b in range(2):
            out[at + 9 + b] = (ch >> (8 * b)) & 0xFF
        for b in range(4):
            out[at + 11 + b] = (sq >> (8 * b)) & 0xFF
        src = base[p] + row_of[i] * n
        out[at + _HEAD:at + _HEAD + n] = flat[src:src + n]
        at += _HEAD + n
