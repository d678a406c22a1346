"""One console per session folder: an exclusive lock held while the console runs.

The lock is ``console.lock`` in the session folder, locked with ``filelock.lock_descriptor`` (``flock`` on
Unix, ``LockFileEx`` on Windows) and holding the owner's PID. The system drops the lock when its process ends, however it ends, so a lock left by
a dead console is simply taken over (its PID is reported as :attr:`SessionLock.previous_pid`).
A second console on the same folder is refused with a :class:`SessionError` naming the PID of the
console that holds it. A folder this process cannot write is not locked (nothing can be saved
over there); :attr:`SessionLock.held` is then False.
"""

from __future__ import annotations

import errno
import logging
import os
from pathlib import Path

from filelock import lock_descriptor

from pipeline.lock_file import pid_in, write_pid

from console.session.session_types import SessionError

log = logging.getLogger(__name__)

LOCK_FILE = "console.lock"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def holder(folder: str | Path) -> int | None:
    """The PID of the running console that holds ``folder``'s lock (0 if unknown), or ``None`` when free.

    Only looks: opens the lock file read-only and tries the lock without waiting, which a console's
    lock refuses (taken, it is dropped at once). A folder without a lock file (or one that cannot be read)
    has no holder.
    """
    try:
        fd = os.open(Path(folder) / LOCK_FILE, os.O_RDONLY)
    except OSError:
        return None
    try:
        if not lock_descriptor(fd, blocking=False):
            return pid_in(fd) or 0
    except OSError:
        return None
    finally:
        os.close(fd)  # also drops the lock if it was taken
    return None


class SessionLock:
    """The exclusive lock on a session ``folder`` (created if missing); use :meth:`acquire`, :meth:`release`.

    Attributes:
        path: The lock file.
        held: Whether this process holds the lock.
        previous_pid: PID left in the lock file by a console that is gone (taken over), else ``None``.
    """

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder).expanduser().resolve()
        self.path = self.folder / LOCK_FILE
        self.held = False
        self.previous_pid: int | None = None
        self._fd: int | None = None

    def acquire(self) -> "SessionLock":
        """Take the lock; raises :class:`SessionError` naming the holder's PID if another console has it."""
        if self._fd is not None:
            return self
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            if exc.errno not in (errno.EACCES, errno.EROFS, errno.EPERM):
                raise SessionError(f"cannot lock the session folder {self.folder}: {exc.strerror or exc}") from None
            try:  # read-only folder: still refuse if a console there holds the lock
                fd = os.open(self.path, os.O_RDONLY)
            except OSError:
                log.warning("session folder %s is not writable: not locked (nothing can be saved there)", self.folder)
                return self
        try:
            taken = lock_descriptor(fd, blocking=False)
        except OSError as exc:
            os.close(fd)
            raise SessionError(f"cannot lock the session folder {self.folder}: {exc.strerror or exc}") from None
        if not taken:
            pid = pid_in(fd)
            os.close(fd)
            who = f"PID {pid}" if pid is not None else "an unknown process"
            raise SessionError(
                f"the session folder {self.folder} is in use by another console ({who}): stop that console, "
                "or start this one with --session DIR (another folder)")
        old = pid_in(fd)
        if old is not None and old != os.getpid():
            self.previous_pid = old
            log.info("session folder %s: took over the lock left by PID %d (%s)", self.folder, old,
                     "still running but not holding it" if _alive(old) else "no longer running")
        write_pid(fd)  # opened read-only: the lock holds, the PID cannot be recorded
        self._fd = fd
        self.held = True
        return self

    def release(self) -> None:
        """Drop the lock (idempotent). The file stays; an empty one means nobody holds it."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            os.ftruncate(fd, 0)
        except OSError:
            pass
        os.close(fd)  # closing releases the lock
        self.held = False

    def __enter__(self) -> "SessionLock":
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
