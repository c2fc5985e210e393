"""File locks (`fcntl.flock`). A lock belongs to an open file: it is released when the file is closed or its
process ends in any way, so a killed process never leaves a lock behind that blocks the next run."""

from __future__ import annotations

import fcntl
import os
from contextlib import contextmanager
from pathlib import Path

from steerlab.errors import SteerlabError


def pid_alive(pid: int) -> bool:
    """Whether a process with this id runs (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


@contextmanager
def waiting_lock(path: str | Path):
    """Hold an exclusive lock on the file `path` (created when absent), waiting while another process holds it."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


@contextmanager
def folder_lock(folder: str | Path, user: str):
    """Hold `folder/.lock`, with this process's id written in it; while another process holds it, a one-line
    error names that process. The lock of a process that died is free again and is taken over."""
    folder = Path(folder)
    fd = os.open(folder / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            raise SteerlabError(f"{folder} is in use by another {user} (pid {pid}); wait for it to end or choose "
                                "another folder") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        try:
            yield
        finally:
            os.ftruncate(fd, 0)
    finally:
        os.close(fd)
