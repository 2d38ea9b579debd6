"""The disk a bag is written to: its device, its free space, the errors that mean it is
full or failing, and the room kept for closing a bag when it fills up (no rclpy).

A recording must end as a bag that every reader takes, however it ends. A full disk
(``ENOSPC``, or a quota's ``EDQUOT``) or a failing one (``EIO``) stops the recording; the bag
is then closed from its last chunk on disk, which needs a little room: the writer keeps
:data:`RESERVE_BYTES` allocated in a reserve file beside the bag and frees it at that
moment, for the bag's summary and ``metadata.yaml`` and the run's ``run.json`` and report.
"""
from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

#: Errors that stop a recording: the disk is full (or the user's quota is), or failing.
DISK_ERRNOS = {errno.ENOSPC: "disk full", errno.EDQUOT: "disk quota exceeded", errno.EIO: "disk I/O error"}
#: Room kept for closing the bag and writing the run's files once the disk is full [bytes].
RESERVE_BYTES = 1 << 20
#: Name of the reserve file in the bag's directory.
RESERVE_NAME = ".space_reserve"


def is_disk_error(exc: BaseException) -> bool:
    """Whether ``exc`` means the disk is full or failing (:data:`DISK_ERRNOS`)."""
    return isinstance(exc, OSError) and exc.errno in DISK_ERRNOS


def existing(path: Path | str) -> Path:
    """``path`` or its nearest existing ancestor (what a not-yet-created output lives on)."""
    path = Path(path).absolute()
    return next((p for p in (path, *path.parents) if p.exists()), Path("/"))


def free_bytes(path: Path | str) -> int:
    """Bytes free for an unprivileged writer on the file system holding ``path``."""
    return shutil.disk_usage(existing(path)).free


def device_of(path: Path | str) -> str:
    """The device (mount source) and mount point holding ``path``, e.g. ``/dev/sda1 on /work``,
    from ``/proc/self/mountinfo`` (the st_dev of ``path``); the mount point alone elsewhere."""
    path = existing(path)
    dev = os.stat(path).st_dev
    try:
        for line in Path("/proc/self/mountinfo").read_text().splitlines():
            fields = line.split()
            major, minor = (int(x) for x in fields[2].split(":"))
            if os.makedev(major, minor) == dev:
                source = fields[fields.index("-") + 2]
                return f"{source} on {fields[4]}"
    except (OSError, ValueError, IndexError):
        pass
    mount = path
    while not os.path.ismount(mount) and mount != mount.parent:
        mount = mount.parent
    return f"the file system on {mount}"


def human(n: float) -> str:
    """Bytes in binary units: ``12.0 KiB``."""
    for unit in ("B", "KiB", "MiB", "GiB"):
        if abs(n) < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} TiB"  # pragma: no cover - the loop returns


def space_line(path: Path | str) -> str:
    """``<device> has <free> free``: the device and free space of ``path``'s file system."""
    return f"{device_of(path)} has {human(free_bytes(path))} free"


def disk_error_line(exc: OSError, path: Path | str) -> str:
    """One line for a disk error while writing under ``path``: what, the device, its free space."""
    return f"{DISK_ERRNOS.get(exc.errno, exc.strerror)} ({exc.strerror}): {space_line(path)}"


def stop_kind(line: str) -> str:
    """What stopped a recording, from its line: ``disk full``, ``disk quota exceeded`` or
    ``disk I/O error`` (:data:`DISK_ERRNOS`); ``disk full`` when the line names none."""
    return next((kind for kind in DISK_ERRNOS.values() if kind in line), "disk full")


def take_reserve(directory: Path, size: int = RESERVE_BYTES) -> Path | None:
    """Allocate the reserve file in ``directory`` (module docstring); None when there is no
    room for it (the bag is then closed with whatever room is left)."""
    path = directory / RESERVE_NAME
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    except OSError:
        return None
    try:
        if hasattr(os, "posix_fallocate"):
            os.posix_fallocate(fd, 0, size)
        else:  # macOS: blocks written are blocks allocated
            os.write(fd, bytes(size))
    except OSError:
        os.close(fd)
        path.unlink(missing_ok=True)
        return None
    os.close(fd)
    return path


def free_reserve(path: Path | None) -> None:
    """Give the reserve's room back (idempotent)."""
    if path is not None:
        path.unlink(missing_ok=True)


#: Bytes a recorded run takes per lockstep step, zstd chunks and uncompressed, with 50 %
#: headroom over sighting_land_vehicle's (the largest built-in graph): 2 s of it at 1 kHz
#: recorded 1.09 MB compressed, 4.24 MB uncompressed (540 B and 2.1 kB per step).
BYTES_PER_STEP = {True: 810, False: 3200}
#: Bytes a run's report takes (its plots and page; sighting_land_vehicle's: 0.72 MB), with headroom.
REPORT_BYTES = 1 << 20


def estimate_run_bytes(duration_s: float, rate_hz: float, compress: bool) -> int:
    """The room a run of ``duration_s`` at ``rate_hz`` lockstep steps needs: its bag, its
    report and the reserve (:data:`BYTES_PER_STEP`, :data:`REPORT_BYTES`, :data:`RESERVE_BYTES`)."""
    return int(duration_s * rate_hz * BYTES_PER_STEP[bool(compress)]) + REPORT_BYTES + RESERVE_BYTES
