"""Fast DDS's shared memory on this host: the run's domain id and the segments a crash leaves.

**Domains.** `/dev/shm` is the host's, so the lock that gives a run its ROS_DOMAIN_ID lives
beside it (`/dev/shm/kartci-dds-domains/<id>.lock`, a sticky folder every user may write, as
/tmp), not in a user's cache folder: two runs never hold one id, whoever runs them and whatever
their KARTCI_CACHE_DIR. A held lock is not enough (a team's own stack or another tool may sit on
the id without kartci's lock), so before it claims an id a run also checks that no live Fast DDS
participant is on it: every shared-memory participant of domain D listens on the discovery
multicast port `7400 + 250 D` (the RTPS well-known port PB + DG * D, Fast DDS's defaults),
i.e. on the segment `fastdds_port<7400 + 250 D>` (`fastrtps_` before Fast DDS 3), holding a
shared `flock` on its `_sl` file while it lives.

**Zombies.** A Fast DDS process that is killed leaves its segments in /dev/shm, and a survivor
that talked to it may leave the dead one's port segments and their mutexes (`sem.<port>_mutex`)
without their lock files. A family (a segment, its `_el`/`_sl` lock files, its mutex) is dead
when no live process keeps it: nobody holds a lock file's `flock` (Fast DDS's own rule, from
`fastdds shm clean`, across users) and no live process we can inspect maps or holds open any
of its files (`/proc/<pid>/maps` and `/proc/<pid>/fd`). Only dead families are removed, before
and after every run. Files of another user are left alone (unless we are root), and while some
process cannot be inspected (another user's), so is a family it could use: group- or
other-writable, or not ours.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import re
import stat
import tempfile
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path

from kartci.errors import RunError

SHM_DIR = Path("/dev/shm")
DOMAINS_FOLDER = "kartci-dds-domains"  # in SHM_DIR: the host-wide domain locks
FIRST_DOMAIN, LAST_DOMAIN = 101, 232  # away from the small ids teams use by hand; 232 is
# the largest id whose ports (7400 + 250 D + offsets) stay below 65536
PORT_BASE, DOMAIN_GAIN = 7400, 250  # RTPS well-known ports: PB, DG (Fast DDS's defaults)
PREFIXES = ("fastdds_", "fastrtps_")  # Fast DDS 3.x, 2.x
# a family member: optional `sem.`, the family (`fastdds_<16 hex>` or `fastdds_port<N>`), then
# nothing (the segment), `_el` / `_sl` (its lock file) or `_mutex` (with `sem.`: its mutex)
_MEMBER = re.compile(r"^(?:sem\.)?((?:fastdds|fastrtps)_(?:[0-9a-z]{16}|port\d{1,5}))"
                     r"(_el|_sl|_mutex)?$")
_LOCK_SUFFIXES = ("_el", "_sl")


def discovery_port(domain_id: int) -> int:
    """The port every participant of `domain_id` listens on for discovery (multicast)."""
    return PORT_BASE + DOMAIN_GAIN * domain_id


def _locked(path: Path) -> bool:
    """Whether a process holds a flock on `path` (Fast DDS's liveness mark of a segment)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return True  # gone or unreadable: not ours to judge
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)  # also drops our probe's lock
    return False


def _maps_device(text: str) -> int:
    """`/proc/<pid>/maps`' device column (`00:1b`, hex major:minor) as an st_dev."""
    major, minor = text.split(":")
    return os.makedev(int(major, 16), int(minor, 16))


def in_use(shm_dir: Path = SHM_DIR) -> tuple[set[tuple[int, int]], bool]:
    """(device, inode) of every file under `shm_dir` a live process maps or holds open, and
    whether some process could not be inspected (another user's, unless we are root)."""
    prefix = str(shm_dir).rstrip("/") + "/"
    used: set[tuple[int, int]] = set()
    hidden = False
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            with (proc / "maps").open(encoding="utf-8", errors="replace") as maps:
                for line in maps:
                    cols = line.split(maxsplit=5)
                    if len(cols) == 6 and cols[5].startswith(prefix):
                        used.add((_maps_device(cols[3]), int(cols[4])))
            for fd in (proc / "fd").iterdir():
                with contextlib.suppress(OSError):
                    if str(fd.readlink()).startswith(prefix):
                        st = fd.stat()
                        used.add((st.st_dev, st.st_ino))
        except PermissionError:
            hidden = True
        except (FileNotFoundError, ProcessLookupError, NotADirectoryError):
            continue  # ended meanwhile
    return used, hidden


def _families(names: Iterable[str]) -> dict[str, list[str]]:
    """Fast DDS's files by family (segment name)."""
    out: dict[str, list[str]] = defaultdict(list)
    for name in names:
        m = _MEMBER.match(name)
        if m and (m.group(2) != "_mutex") == (not name.startswith("sem.")):
            out[m.group(1)].append(name)
    return dict(out)


class _Judge:
    """Whether a family lives, with the process scan made once and only if needed."""

    def __init__(self, shm_dir: Path) -> None:
        self.shm_dir = shm_dir
        self._scan: tuple[set[tuple[int, int]], bool] | None = None

    def scan(self) -> tuple[set[tuple[int, int]], bool]:
        if self._scan is None:
            self._scan = in_use(self.shm_dir)
        return self._scan

    def alive(self, members: list[str]) -> bool:
        """Held by a lock, or used by a live process (or maybe by one we cannot see)."""
        if any(self._locked(n) for n in members if n.endswith(_LOCK_SUFFIXES)):
            return True
        used, hidden = self.scan()
        for name in members:
            try:
                st = os.lstat(self.shm_dir / name)
            except OSError:
                continue
            if (st.st_dev, st.st_ino) in used:
                return True
            if hidden and (st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
                           or st.st_uid != os.geteuid()):
                return True  # a process we cannot see may use it: cannot prove it unused
        return False

    def _locked(self, name: str) -> bool:
        return _locked(self.shm_dir / name)


def _removable(path: Path) -> bool:
    """Ours to remove: our file (or we are root), a regular file."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISREG(st.st_mode) and (os.geteuid() in (0, st.st_uid))


def clean_zombies(shm_dir: Path = SHM_DIR) -> list[str]:
    """Remove every Fast DDS family in `shm_dir` no live process keeps; the names removed."""
    try:
        families = _families(p.name for p in shm_dir.iterdir())
    except OSError:
        return []
    judge = _Judge(shm_dir)
    removed = []
    for _, members in sorted(families.items()):
        if not all(_removable(shm_dir / n) for n in members) or judge.alive(members):
            continue
        for name in sorted(members):
            with contextlib.suppress(OSError):
                (shm_dir / name).unlink()
                removed.append(name)
    return removed


def occupied(domain_id: int, shm_dir: Path = SHM_DIR) -> bool:
    """Whether a live Fast DDS participant (shared memory) is on `domain_id`."""
    ports = [f"{prefix}port{discovery_port(domain_id)}" for prefix in PREFIXES]
    try:
        families = _families(p.name for p in shm_dir.iterdir())
    except OSError:
        return False
    judge = _Judge(shm_dir)
    return any(judge.alive(families[port]) for port in ports if port in families)


def domains_folder(shm_dir: Path = SHM_DIR) -> Path:
    """The host-wide folder of domain locks: made sticky and writable by every user (as /tmp),
    atomically (made aside, then renamed into place), so another user's run can lock in it."""
    path = shm_dir / DOMAINS_FOLDER
    try:
        if not path.exists():
            aside = Path(tempfile.mkdtemp(prefix=f".{DOMAINS_FOLDER}-", dir=shm_dir))
            os.chmod(aside, 0o1777)
            try:
                aside.rename(path)
            except OSError:  # made meanwhile by another run
                aside.rmdir()
        st = os.lstat(path)
    except OSError as err:
        raise RunError(f"cannot make the host's kartci DDS domain locks in {path}: "
                       f"{err.strerror or err}") from err
    if not stat.S_ISDIR(st.st_mode) or stat.S_IMODE(st.st_mode) != 0o1777:
        raise RunError(f"{path}: the host's kartci DDS domain locks need a folder every user "
                       f"may write (sticky, mode 1777), not mode {stat.S_IMODE(st.st_mode):o} "
                       f"owned by uid {st.st_uid}; remove it (its owner or root)")
    return path


def _open_lock(path: Path) -> int:
    """A descriptor of the lock file `path`, made if missing (read-only: flock needs no more,
    and another user's lock file opens so; no O_CREAT on an existing file, which
    fs.protected_regular refuses in a sticky folder)."""
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC
    for _ in range(3):
        try:
            return os.open(path, flags)
        except FileNotFoundError:
            try:
                fd = os.open(path, flags | os.O_CREAT | os.O_EXCL, 0o444)
            except FileExistsError:
                continue
            os.fchmod(fd, 0o444)  # whatever the umask
            return fd
    raise OSError(errno.EEXIST, "lock file keeps changing", str(path))


class Domain:
    """A ROS_DOMAIN_ID held for one run (released by `release()` or the process's end): its
    host-wide lock taken and no live participant on it."""

    def __init__(self, folder: Path | None = None, shm_dir: Path = SHM_DIR) -> None:
        if folder is None:
            folder = domains_folder(shm_dir)
        else:  # a private one (tests)
            folder.mkdir(parents=True, exist_ok=True)
        self.skipped: list[int] = []  # ids with a live participant but no kartci lock
        for domain_id in range(FIRST_DOMAIN, LAST_DOMAIN + 1):
            try:
                fd = _open_lock(folder / f"{domain_id}.lock")
            except OSError as err:
                raise RunError(f"cannot take a ROS_DOMAIN_ID: {folder / f'{domain_id}.lock'}: "
                               f"{err.strerror or err}") from err
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                continue
            if occupied(domain_id, shm_dir):
                os.close(fd)
                self.skipped.append(domain_id)
                continue
            self.id, self._fd = domain_id, fd
            return
        raise RunError(f"no free ROS_DOMAIN_ID in {FIRST_DOMAIN}..{LAST_DOMAIN}: "
                       f"{LAST_DOMAIN - FIRST_DOMAIN + 1 - len(self.skipped)} kartci runs on "
                       f"DDS at once, {len(self.skipped)} ids used by other DDS participants")

    def release(self) -> None:
        """Let another run take the id (idempotent)."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1
