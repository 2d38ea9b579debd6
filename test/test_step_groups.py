"""StepGroups and EagerStepGroups, used the way the LOS and encoder-fusion controllers use
them, release exactly what the controllers' former hand-rolled ``_pending`` blocks released
(reproduced here as the reference), on seeded random arrival orders with lost, repeated and
late inputs and bag-loop back-jumps."""
from __future__ import annotations

import numpy as np
import pytest

from gimbal_kinematics.timing.sync import EagerStepGroups, StepGroups

RATE_HZ, RESET_BACKJUMP_S = 1000.0, 0.5
INS_EVERY = 10
ESTIMATES = ("bias",)


def los_needs(step: int) -> tuple[str, ...]:
    return ("gyro", "enc", "ins") + ESTIMATES if step % INS_EVERY == 0 else ("gyro", "enc")


class LosReference:
    """The LOS controller node's input handling before StepGroups (its ``_on_input``)."""

    def __init__(self) -> None:
        self.pending: dict[int, dict] = {}
        self.done: int | None = None
        self.events: list = []

    def on_input(self, kind: str, k: int, msg) -> None:
        if self.done is not None and k <= self.done:
            if (self.done - k) / RATE_HZ > RESET_BACKJUMP_S:
                self.pending.clear()
                self.done = None
            else:
                self.events.append(("rejected", kind, k, self.done))
                return
        if kind == "bias" and k % INS_EVERY != 0:
            self.events.append(("estimate", k, msg))
            return
        self.pending.setdefault(k, {})[kind] = msg
        for step in sorted(self.pending):
            group = self.pending[step]
            if not all(need in group for need in los_needs(step)):
                break
            del self.pending[step]
            self.events.append(("control", step, sorted(group.items())))
            self.done = step


class LosWithStepGroups:
    """The same handling as the node now does it."""

    def __init__(self) -> None:
        self.sync = StepGroups(los_needs, RESET_BACKJUMP_S * RATE_HZ)
        self.events: list = []

    def on_input(self, kind: str, k: int, msg) -> None:
        if not self.sync.admit(kind, k):
            self.events.append(("rejected", kind, k, self.sync.last_step))
            return
        if kind == "bias" and k % INS_EVERY != 0:
            self.events.append(("estimate", k, msg))
            return
        for step, group in self.sync.add(kind, k, msg):
            self.events.append(("control", step, sorted(group.items())))


ENC_EVERY, BASE_EVERY, STALE = 2, 5, 30


def fusion_needs(step: int) -> tuple[str, ...]:
    return ("gyro",) + (("enc",) if step % ENC_EVERY == 0 else ()) + (("base",) if step % BASE_EVERY == 0 else ())


class FusionReference:
    """The encoder-fusion controller node's input handling before EagerStepGroups."""

    def __init__(self) -> None:
        self.pending: dict[int, dict] = {}
        self.dropped = 0
        self.events: list = []

    def on_input(self, kind: str, k: int, msg) -> None:
        group = self.pending.setdefault(k, {})
        group[kind] = msg
        if not ("gyro" in group and (k % ENC_EVERY != 0 or "enc" in group)
                and (k % BASE_EVERY != 0 or "base" in group)):
            return
        del self.pending[k]
        for step in [s for s in self.pending if s < k - STALE]:
            del self.pending[step]
            self.dropped += 1
            self.events.append(("warning", f"step {step}: inputs never complete; skipped ({self.dropped} skipped)"))
        self.events.append(("control", k, sorted(group.items())))


class Log:
    """Stands in for the node's rclpy logger."""

    def __init__(self, events: list) -> None:
        self.events = events

    def warning(self, text: str, throttle_duration_sec: float = 0.0) -> None:
        self.events.append(("warning", text))


class FusionWithEagerStepGroups:
    def __init__(self) -> None:
        self.events: list = []
        self.sync = EagerStepGroups(fusion_needs, STALE)
        self.log = Log(self.events)

    def on_input(self, kind: str, k: int, msg) -> None:
        group = self.sync.add(kind, k, msg, self.log)
        if group is not None:
            self.events.append(("control", k, sorted(group.items())))


def arrivals(rng: np.random.Generator, needs, kinds: tuple[str, ...], n_steps: int, *, p_lost: float,
             p_repeat: float, p_backjump: float) -> list[tuple[str, int, int]]:
    """(kind, step, payload) in a shuffled arrival order: each step's inputs (plus estimates
    off the steps that wait for them) within a window of a few steps, some lost, some sent
    twice, and now and then the stream jumps back (a bag loop) or far back."""
    out: list[tuple[str, int, int]] = []
    k, payload = 0, 0
    for _ in range(n_steps):
        due = list(needs(k)) + [x for x in kinds if x not in needs(k) and rng.random() < 0.05]
        for kind in due:
            if rng.random() < p_lost:
                continue
            for _ in range(2 if rng.random() < p_repeat else 1):
                payload += 1
                out.append((kind, k, payload))
        k += 1
        if rng.random() < p_backjump:
            k = max(0, k - int(rng.choice([3, 40, 498, 499, 500, 501, 502, 700, 2000])))
    # shuffle locally: each message moves by up to 3 places
    keys = np.arange(len(out)) + rng.uniform(0.0, 3.0, len(out))
    return [out[i] for i in np.argsort(keys, kind="stable")]


@pytest.mark.parametrize("seed", range(8))
def test_step_groups_release_what_the_los_controller_released(seed):
    rng = np.random.default_rng(seed)
    msgs = arrivals(rng, los_needs, ("gyro", "enc", "ins", "bias"), 3000, p_lost=0.0, p_repeat=0.02,
                    p_backjump=0.003)
    ref, new = LosReference(), LosWithStepGroups()
    for kind, k, payload in msgs:
        ref.on_input(kind, k, payload)
        new.on_input(kind, k, payload)
    assert new.events == ref.events
    kinds = {e[0] for e in ref.events}
    assert {"control", "rejected", "estimate"} <= kinds and len(ref.events) > 1000 and new.sync.restarts > 0


@pytest.mark.parametrize("seed", range(8))
def test_eager_step_groups_release_what_the_encoder_fusion_controller_released(seed):
    rng = np.random.default_rng(100 + seed)
    msgs = arrivals(rng, fusion_needs, ("gyro", "enc", "base"), 3000, p_lost=0.02, p_repeat=0.03,
                    p_backjump=0.002)
    ref, new = FusionReference(), FusionWithEagerStepGroups()
    for kind, k, payload in msgs:
        ref.on_input(kind, k, payload)
        new.on_input(kind, k, payload)
    assert new.events == ref.events and new.sync.dropped == ref.dropped
    assert ref.dropped > 0 and len(ref.events) > 1000


def test_eager_step_groups_release_a_complete_step_ahead_of_an_older_incomplete_one():
    sync = EagerStepGroups(lambda step: ("a", "b"), stale_steps=2)
    assert sync.add("a", 0, "a0") is None              # step 0 waits for b
    assert sync.add("a", 1, "a1") is None
    assert sync.add("b", 1, "b1") == {"a": "a1", "b": "b1"}   # step 1 goes; step 0 still waits
    assert sync.add("a", 3, "a3") is None and sync.add("b", 3, "b3") == {"a": "a3", "b": "b3"}
    assert sync.dropped == 1                            # step 0 < 3 - 2: forgotten
    assert sync.add("b", 0, "late") is None             # ... so a late input opens it again
