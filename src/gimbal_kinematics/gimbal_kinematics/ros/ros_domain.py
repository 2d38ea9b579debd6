"""Keep DDS on this host and give each concurrent run its own ROS_DOMAIN_ID.

Fast DDS multicasts discovery on every interface unless told otherwise, and two runs on
one domain see each other's topics. A run therefore (1) sets
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` unless the user chose a range, and (2) claims
a domain id no other run on this machine holds. A claim is an exclusive ``flock`` on a
per-id lock file: the kernel drops it when the holding process exits, however it exits,
so a crashed run never leaks its id.
"""
from __future__ import annotations

import ctypes
import fcntl
import os
import signal
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Callable, MutableMapping

#: Domain ids handed out. 0 is left to the user's own systems; Fast DDS derives UDP ports
#: from the id, and ids above 101 collide with Linux's ephemeral port range.
DOMAIN_IDS = range(1, 102)
LOCK_DIR = Path(tempfile.gettempdir()) / "gimbal_ros_domains"


@dataclass
class DomainClaim:
    """A claimed ROS domain id; released by :meth:`release` or when the process exits."""

    domain_id: int
    _lock_file: IO[str] | None = field(default=None, repr=False)

    def release(self) -> None:
        if self._lock_file is not None:
            self._lock_file.close()
            self._lock_file = None


def claim_domain_id(ids: range = DOMAIN_IDS, lock_dir: Path = LOCK_DIR) -> DomainClaim:
    """Claim the lowest domain id in ``ids`` that no other process on this host holds.

    Raises ``RuntimeError`` when every id is taken.
    """
    lock_dir.mkdir(parents=True, exist_ok=True)
    for domain_id in ids:
        handle = open(lock_dir / f"{domain_id}.lock", "a+", encoding="ascii")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            continue
        return DomainClaim(domain_id, handle)
    raise RuntimeError(f"no free ROS_DOMAIN_ID in {ids.start}..{ids.stop - 1} on this host")


def localhost_env(env: MutableMapping[str, str] | None = None) -> MutableMapping[str, str]:
    """Set ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` in ``env`` (default ``os.environ``)
    unless a range is already set, and return ``env``."""
    env = os.environ if env is None else env
    if not env.get("ROS_AUTOMATIC_DISCOVERY_RANGE"):
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return env


#: Linux prctl option: the signal a process gets when the thread that started it dies.
PR_SET_PDEATHSIG = 1


def die_with_parent(signum: int = signal.SIGTERM) -> Callable[[], None]:
    """A ``preexec_fn`` for a run's child process (a node, a child ``gimbal-run``): it gets
    ``signum`` when the process starting it dies, however it dies (SIGKILL included;
    Linux ``PR_SET_PDEATHSIG``), and stops as on that signal, so no node outlives its run.
    libc is resolved here, before the fork: the child only makes the call. A parent that
    died before the call is caught by comparing the parent pid. Elsewhere than Linux: a no-op."""
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return lambda: None
    parent = os.getpid()

    def preexec() -> None:
        prctl(PR_SET_PDEATHSIG, int(signum))
        if os.getppid() != parent:
            os.kill(os.getpid(), signum)
    return preexec
