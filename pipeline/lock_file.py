"""The PID a lock file holds: who has the lock (model fetches, console sessions).

Both locks (:mod:`pipeline.models.fetch_lock`, ``console/session/session_lock.py``) lock their file with
``filelock.lock_descriptor`` (``flock`` on Unix, ``LockFileEx`` on Windows: the system drops the lock when its
process ends, however it ends) and write the holder's PID into it so that a process refused or kept waiting
can name it.
"""

from __future__ import annotations

import os


def pid_in(fd: int) -> int | None:
    """The PID written in the open lock file ``fd`` (``None``: empty or unreadable)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        text = os.read(fd, 64).decode("ascii", "replace").strip()
        return int(text.split()[0]) if text else None
    except (OSError, ValueError, IndexError):
        return None


def write_pid(fd: int) -> None:
    """Replace the lock file's contents with this process's PID (best effort: a read-only file keeps the
    lock, only the PID is not recorded)."""
    try:
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
    except OSError:
        pass


__all__ = ["pid_in", "write_pid"]
