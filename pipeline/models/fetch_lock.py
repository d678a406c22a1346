"""One fetch at a time per model folder: an exclusive lock on ``<folder>/.fetch.lock`` (``filelock``).

Like the console's session lock (``console/session/session_lock.py``): the lock file holds the owner's PID
and the kernel drops the lock when its process ends, however it ends. A second fetch of the same
model into the same folder waits for the first (saying so, with the holder's PID) and then finds
the files in place. The lock file is removed on release; a waiter that took the lock on a removed
file (its inode no longer at the path) opens the new one and locks again. A folder this process
cannot write is not locked (nothing can be fetched into it; the files already there are only read).
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import Callable

from filelock import lock_descriptor

from pipeline.lock_file import pid_in, write_pid

LOCK_FILE = ".fetch.lock"
_READ_ONLY = (errno.EACCES, errno.EPERM, errno.EROFS)


class FetchLock:
    """The exclusive fetch lock of a model ``folder`` (``<models dir>/<name>/``, created if missing).

    Use as a context manager. ``what`` names the model in the waiting message given to ``log``.
    Attributes: ``held`` (this process holds it), ``waited_for`` (PID of the fetch it waited for, 0 if
    unknown, ``None`` when it did not wait).
    """

    def __init__(self, folder: Path, what: str, log: Callable[[str], None]) -> None:
        self.folder = Path(folder)
        self.path = self.folder / LOCK_FILE
        self.what = what
        self.log = log
        self.held = False
        self.waited_for: int | None = None
        self._fd: int | None = None

    def acquire(self) -> "FetchLock":
        """Take the lock, waiting for another fetch that holds it. A read-only folder is not locked."""
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:
                if exc.errno in _READ_ONLY:
                    return self  # cannot write here: nothing will be written, so nothing to guard
                raise
            if not lock_descriptor(fd, blocking=False):
                pid = pid_in(fd)
                if self.waited_for is None:
                    self.waited_for = pid or 0
                    self.log(f"waiting for another fetch of {self.what} (pid {pid if pid else 'unknown'}) "
                             f"into {self.folder}")
                lock_descriptor(fd, blocking=True, poll_interval=0.05)  # released when that process ends, however it ends
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if not same:  # the holder removed that file on release: lock the current one
                os.close(fd)
                self.folder.mkdir(parents=True, exist_ok=True)
                continue
            break
        write_pid(fd)
        self._fd = fd
        self.held = True
        return self

    def release(self) -> None:
        """Remove the lock file, then drop the lock (idempotent)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            self.path.unlink()
        except OSError:
            pass
        os.close(fd)
        self.held = False

    def __enter__(self) -> "FetchLock":
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
