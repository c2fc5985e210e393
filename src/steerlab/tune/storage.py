"""Where a study lives: a journal file (the default, `OUT/study.journal`) or an RDB storage (SQLite, PostgreSQL,
MySQL) with heartbeats, so that a killed worker's trial is failed and retried. Workers on any number of
machines share one."""

from __future__ import annotations

import contextlib
import json
import os
import warnings
from pathlib import Path

from steerlab.errors import SteerlabError, warn

# seconds: a worker's heartbeat interval, and the silence after which its trial is failed and retried (RDB
# storages). The environment variable STEERLAB_TUNE_HEARTBEAT="INTERVAL,GRACE" (whole seconds) replaces it, e.g. "1,3"
# in the tests, so that a killed worker's trial is retried within seconds.
HEARTBEAT = (30, 90)
CONNECT_TIMEOUT = 10  # seconds to wait for a PostgreSQL or MySQL server (a URL's own connect_timeout= wins)


def optuna():
    """Optuna, quiet (steerlab reports trials itself)."""
    try:
        import optuna
    except ImportError:
        raise SteerlabError("steerlab tune needs optuna and scikit-learn: pip install optuna scikit-learn") from None
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    return optuna


def heartbeat() -> tuple[int, int]:
    """(interval, grace period) in seconds: HEARTBEAT, or STEERLAB_TUNE_HEARTBEAT="INTERVAL,GRACE"."""
    text = os.environ.get("STEERLAB_TUNE_HEARTBEAT", "").strip()
    if not text:
        return HEARTBEAT
    try:
        interval, grace = (int(x) for x in text.split(","))
    except ValueError:
        interval = grace = 0
    if not 0 < interval < grace:
        raise SteerlabError(f"STEERLAB_TUNE_HEARTBEAT={text!r}: expected INTERVAL,GRACE in whole seconds with "
                            "0 < INTERVAL < GRACE, e.g. 30,90")
    return interval, grace


def shown_url(url: str) -> str:
    """The storage URL as messages show it: without its password."""
    try:
        from sqlalchemy.engine import make_url

        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001 - not a URL SQLAlchemy can parse: keep only what precedes the host
        scheme, sep, rest = url.partition("://")
        return f"{scheme}{sep}***@{rest.rpartition('@')[2]}" if "@" in rest else url


def storage_of(url: str | None, out: Path, join: bool = False):
    """An Optuna storage: a journal file (default `<out>/study.journal`, or a path / journal:PATH), or an RDB URL
    (sqlite:///, postgresql://, mysql://) with heartbeats, so a killed worker's trial is failed and retried.
    `postgresql://` uses the psycopg (3) driver; connecting gives up after CONNECT_TIMEOUT seconds. `join`: the
    storage must exist (a journal or SQLite file is not created)."""
    optuna()
    from optuna.storages import JournalStorage, RDBStorage, RetryHeartbeatStaleTrialCallback
    from optuna.storages.journal import JournalFileBackend

    url = url or str(out / "study.journal")
    scheme = url.split(":", 1)[0]
    local = url[len("sqlite:///"):] if scheme == "sqlite" else None if "://" in url else url.removeprefix("journal:")
    if join and local is not None and not Path(local).is_file():
        raise SteerlabError(f"{local}: no such file, so no study to join; check steerlab tune --storage, or start the "
                            "study without --join")
    if scheme.split("+", 1)[0] in ("sqlite", "postgresql", "mysql"):  # postgresql+psycopg2://...
        interval, grace = heartbeat()
        engine = url
        if scheme == "postgresql":  # the driver requirements.txt installs, whatever SQLAlchemy's default
            engine = "postgresql+psycopg" + url[len(scheme):]
        kwargs = {}
        if scheme != "sqlite" and "connect_timeout=" not in url:
            kwargs["connect_args"] = {"connect_timeout": CONNECT_TIMEOUT}
        try:
            with warnings.catch_warnings(), _schema_lock(engine, kwargs):  # heartbeats: experimental in Optuna
                warnings.simplefilter("ignore")
                return RDBStorage(engine, engine_kwargs=kwargs, heartbeat_interval=interval, grace_period=grace,
                                  heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(max_retry=2))
        except ModuleNotFoundError as e:
            raise SteerlabError(f"cannot open storage {shown_url(url)}: its database driver is not installed "
                                f"(no module {e.name!r}; for PostgreSQL: pip install 'psycopg[binary]')") from None
        except Exception as e:  # noqa: BLE001 - SQLAlchemy raises many types for a bad URL or server
            raise SteerlabError(f"cannot open storage {shown_url(url)}: {_first_line(e)}; check the URL "
                                "and the database server") from None
    path = url.removeprefix("journal:")
    if "://" in path or not path.endswith((".journal", ".log")):
        raise SteerlabError(f"unknown storage {url!r}: use a journal file (*.journal, *.log, journal:PATH) or "
                            "an RDB URL (sqlite:///study.db, postgresql://user:pass@host/db)")
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _check_journal_access(path)
        _repair_journal(path)
        return JournalStorage(JournalFileBackend(str(path)))
    except ValueError as e:  # Optuna's reader: a damaged line before the last one
        raise SteerlabError(f"{path}: a line before the last one is damaged ({e.__class__.__name__}); only a torn "
                            "last line can be skipped: remove the damaged line") from None
    except PermissionError as e:
        raise SteerlabError(f"{e.filename or path}: permission denied (the study's journal needs to be readable "
                            "and writable, with its folder writable for the lock file)") from None


@contextlib.contextmanager
def _schema_lock(url: str, kwargs: dict):
    """On PostgreSQL, one worker at a time opens the storage: workers started together on an empty database
    would otherwise create Optuna's tables together, and all but one fail (a unique violation in PostgreSQL's
    catalog). A session-level advisory lock, released when its connection closes, also if the worker dies."""
    if not url.startswith("postgresql"):
        yield
        return
    import sqlalchemy

    engine = sqlalchemy.create_engine(url, poolclass=sqlalchemy.pool.NullPool, **kwargs)
    try:
        with engine.connect() as conn:
            conn.execute(sqlalchemy.text("SELECT pg_advisory_lock(7355608)"))  # any fixed key: steerlab's
            try:
                yield
            finally:
                conn.execute(sqlalchemy.text("SELECT pg_advisory_unlock(7355608)"))
    finally:
        engine.dispose()


def _first_line(e: Exception) -> str:
    """An exception as one line: a database driver's message without SQLAlchemy's wrapping and links."""
    orig = getattr(e, "orig", None) or e  # sqlalchemy.exc.DBAPIError wraps the driver's exception
    lines = [line.strip() for line in str(orig).splitlines() if line.strip()]
    text = "; ".join(lines[:2]) if lines else ""
    return f"{orig.__class__.__name__}: {text}" if text else orig.__class__.__name__


def _check_journal_access(path: Path) -> None:
    """A journal that this worker cannot write (or whose folder cannot take Optuna's lock file) is refused
    before anything runs, naming the file."""
    if path.is_dir():
        raise SteerlabError(f"{path}: a folder, not a journal file: name a file in it")
    if path.exists() and not os.access(path, os.R_OK | os.W_OK):
        raise SteerlabError(f"{path}: the journal file is not writable (permission denied); the study needs "
                            "to append to it: make it writable or choose another steerlab tune --storage")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise SteerlabError(f"{path.parent}: the journal's folder is not writable (permission denied); the "
                            f"study needs it for {path.name} and its lock file")


def _repair_journal(path: Path) -> None:
    """A worker killed while appending leaves a torn last line, after which Optuna can never read the journal
    again. Skip it: with a warning naming the file, its bytes move to `<journal>.torn` (appended, so nothing
    is ever lost) and the journal ends after its last whole line. A last line that is whole JSON without its
    line end gets the line end. Done under Optuna's own journal lock, so no worker is writing meanwhile."""
    from optuna.storages.journal import JournalFileSymlinkLock

    if not path.is_file() or path.stat().st_size == 0:
        return
    lock = JournalFileSymlinkLock(str(path))
    lock.acquire()
    try:
        with open(path, "rb+") as f:
            size = end = f.seek(0, os.SEEK_END)
            tail = b""
            while True:  # read back to the line end before the last line
                start = max(0, end - (1 << 16))
                f.seek(start)
                tail = f.read(end - start) + tail
                end = start
                cut = tail.rfind(b"\n", 0, len(tail) - 1)
                if cut >= 0 or start == 0:
                    break
            last = tail[cut + 1:]
            try:
                whole = isinstance(json.loads(last), dict)
            except ValueError:  # not JSON, NUL bytes, half a UTF-8 character
                whole = False
            if whole:
                if not last.endswith(b"\n"):
                    f.seek(0, os.SEEK_END)
                    f.write(b"\n")
                return
            with open(path.with_name(path.name + ".torn"), "ab") as backup:
                backup.write(last)
            f.truncate(size - len(last))
        warn(f"{path}: its last line is torn ({len(last)} bytes that are not a whole JSON record, left by a "
             f"worker that stopped while writing); skipped it and kept its bytes in {path.name}.torn")
    finally:
        lock.release()
