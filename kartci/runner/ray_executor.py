"""Jobs as Ray tasks: a new local Ray instance by default, or an existing cluster by address.

Optional (`pip install "kartci[ray]"`). On a cluster every node needs kartci installed and OUT
on a shared filesystem, since each task writes its scenario folder there itself. Ray tasks
report no live sim time: the progress view shows them queued until they finish. A local instance
listens and talks on 127.0.0.1 only (docs/howto/ray.md says how, and what Ray does otherwise).
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, nullcontext
from typing import Any

from kartci.errors import RunError, SpecError
from kartci.portable import child_vars
from kartci.runner.events import Event, EventKind, Listener, lost
from kartci.runner.jobs import Context, Job, Outcome, run_job


def _ray() -> Any:
    try:
        return importlib.import_module("ray")
    except ImportError:
        raise SpecError('--executor ray needs Ray: pip install "kartci[ray]"') from None


LOOPBACK = "127.0.0.1"


@contextmanager
def _single_machine() -> Iterator[None]:
    """Ray's single-machine mode while a local instance starts. Ray 2.60 replaces a loopback
    node address by the machine's (`services.resolve_ip_for_localhost`) unless this mode is on
    (`ray_constants.ENABLE_RAY_CLUSTER`, read once at import from
    RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER); with the node on 127.0.0.1, GCS, raylet, agents and
    workers bind their servers there instead of on every interface. Restored after start so
    that a later `ray.init` in the same process is Ray's own."""
    constants: Any = importlib.import_module("ray._private.ray_constants")
    before = constants.ENABLE_RAY_CLUSTER
    constants.ENABLE_RAY_CLUSTER = False
    try:
        yield
    finally:
        constants.ENABLE_RAY_CLUSTER = before


def start(ray: Any, address: str | None, workers: int) -> None:
    """Join the cluster at `address`, or start a local instance of `workers` CPUs on 127.0.0.1."""
    options: dict[str, Any] = {"address": address, "num_cpus": None} if address else {
        "address": "local", "num_cpus": workers, "_node_ip_address": LOOPBACK}
    with nullcontext() if address else _single_machine():
        try:
            ray.init(**options, include_dashboard=False, log_to_driver=False,
                     logging_level=logging.WARNING,
                     runtime_env={"env_vars": child_vars()})  # kartci.portable
        except Exception as err:  # an unreachable address, a broken local start
            raise RunError(f"cannot start Ray ({address or 'local'}): {err}") from None


def ray_tasks(jobs: Sequence[Job], ctx: Context, emit: Listener, workers: int,
              address: str | None) -> Iterator[Outcome]:
    """Run the jobs as Ray tasks of one CPU each, on a new local instance of `workers` CPUs or the
    cluster at `address`; yields outcomes as tasks finish."""
    ray = _ray()
    started = not ray.is_initialized()
    if started:
        start(ray, address, workers)
    try:
        task = ray.remote(num_cpus=1, max_retries=0,
                          runtime_env={"env_vars": child_vars()})(run_job)
        refs = {task.remote(job, ctx): job for job in jobs}
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                job = refs.pop(ref)
                try:
                    outcome: Outcome = ray.get(ref)
                except Exception as err:  # the task's worker died
                    outcome = lost(job, ctx, f"Ray task failed: {type(err).__name__}: {err}")
                emit(Event(EventKind.FINISHED, job.folder, outcome=outcome))
                yield outcome
    finally:
        if started:
            ray.shutdown()
