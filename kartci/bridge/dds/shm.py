"""Fast DDS's shared memory on this host: the run's domain id and the segments it leaves.

Each kartci run on DDS takes a domain id no other kartci run of this host holds (a lock file),
so `-j N` runs are separate graphs. A Fast DDS process that is killed leaves its segments in
/dev/shm; they are zombies once nobody holds their lock file (Fast DDS keeps a `flock` on
`<segment>_el` or `_sl` while it uses one), which is the rule of Fast DDS's own
`fastdds shm clean`, applied here after every run and before the next.
"""

from __future__ import annotations

import fcntl
import os
import re
from pathlib import Path
from typing import IO

from kartci.cachedir import cache_dir
from kartci.errors import RunError

SHM_DIR = Path("/dev/shm")
FIRST_DOMAIN, LAST_DOMAIN = 101, 232  # away from the small ids teams use by hand
_LOCK = re.compile(r"^fastdds_(?:[0-9a-z]{16}|port\d{1,5})_[es]l$")


def _locked(path: Path) -> bool:
    """Whether a process holds a flock on `path` (Fast DDS's liveness mark of a segment)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return True  # gone or unreadable: not ours to remove
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


def clean_zombies(shm_dir: Path = SHM_DIR) -> list[str]:
    """Remove Fast DDS segments, ports and port mutexes nobody holds; their names."""
    try:
        names = sorted(p.name for p in shm_dir.iterdir())
    except OSError:
        return []
    removed = []
    for name in filter(_LOCK.match, names):
        if _locked(shm_dir / name):
            continue
        base = name[:-3]
        for victim in (base, name, f"sem.{base}_mutex"):
            try:
                (shm_dir / victim).unlink()
                removed.append(victim)
            except OSError:
                continue
    return removed


class Domain:
    """A ROS_DOMAIN_ID held for one run (released by `release()` or the process's end)."""

    def __init__(self, folder: Path | None = None) -> None:
        folder = folder or cache_dir() / "dds-domains"
        folder.mkdir(parents=True, exist_ok=True)
        for domain_id in range(FIRST_DOMAIN, LAST_DOMAIN + 1):
            f = (folder / f"{domain_id}.lock").open("a")
            try:
                fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                f.close()
                continue
            self.id, self._file = domain_id, f
            return
        raise RunError(f"no free ROS_DOMAIN_ID in {FIRST_DOMAIN}..{LAST_DOMAIN}: "
                       f"{LAST_DOMAIN - FIRST_DOMAIN + 1} kartci runs on DDS at once")

    def release(self) -> None:
        """Let another run take the id."""
        f: IO[str] = self._file
        if not f.closed:
            f.close()
