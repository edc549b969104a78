"""Work done in a pinned child process started as its own command.

A Python process that was not started with kartci's pinned environment (a user's script, a
pytest without xdist: see kartci.portable) computes its runs in a fresh process that is:
`python -P -m kartci.runner.pinned FD`. It is deliberately not a multiprocessing child: spawn
starts by importing the caller's `__main__`, so a script calling `kartci.run(...)` at top level
without `if __name__ == "__main__":` ran its own body again inside every run. This child
imports only kartci and what the work names (the caller's `sys.path` and project are handed
over first), and sends back the work's value, or the exception it raised (the same class and
message the caller would have seen in process), through a pipe of its own (`FD`): the work's
stdout and stderr stay the caller's.
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
from collections.abc import Callable
from enum import Enum
from typing import Any, TypeVar

from kartci import portable, project
from kartci.errors import RunError
from kartci.project import Project

T = TypeVar("T")


class Reply(Enum):
    """What the child sends back."""

    VALUE = "value"  # the work's return value
    ERROR = "error"  # the exception it raised
    CANNOT_LOAD = "cannot load"  # the work names something only the caller has (its __main__)


class NotPortable(Exception):  # noqa: N818  (not an error of the work: the caller runs it)
    """The work could not be loaded in the child (a class defined in the caller's `__main__`,
    which the child by design does not import): the caller does it in its own process."""


def call_pinned(proj: Project | None, fn: Callable[..., T], *args: Any) -> T:
    """`fn(*args)` in a fresh pinned child process, in the project `proj` (whose plugins it
    imports; None: the child's working directory's); its exception is raised here as it was
    raised there. NotPortable when the child cannot load `fn` or `args`."""
    request = pickle.dumps((list(sys.path), proj, pickle.dumps((fn, args))))
    read_end, write_end = os.pipe()
    env = portable.pinned_env(os.environ)
    try:
        child = subprocess.Popen([sys.executable, "-P", "-m", __name__, str(write_end)],
                                 stdin=subprocess.PIPE, pass_fds=(write_end,), env=env)
    finally:
        os.close(write_end)
    try:
        with os.fdopen(read_end, "rb") as replies:
            assert child.stdin is not None
            child.stdin.write(request)
            child.stdin.close()
            data = replies.read()
        code = child.wait()
    finally:  # an interrupt here (Ctrl-C reaches the child too) must not leave it running
        if child.poll() is None:
            child.kill()
            child.wait()
    if not data:
        how = (f"killed by {signal.Signals(-code).name}" if code < 0 else f"exit code {code}")
        raise RunError(f"run crashed: the pinned child process ended without a result ({how})")
    kind, value = pickle.loads(data)
    if kind is Reply.CANNOT_LOAD:
        raise NotPortable(value)
    if kind is Reply.ERROR:
        raise value
    result: T = value
    return result


def _reply(kind: Reply, value: object) -> bytes:
    try:
        return pickle.dumps((kind, value))
    except Exception as err:  # an exception that cannot travel: its class and text do
        if not isinstance(value, BaseException):
            value = err
        text = f"run crashed: {type(value).__name__}: {value}"
        return pickle.dumps((Reply.ERROR, RunError(text)))


def main() -> None:
    """The child: read the request from stdin, do the work, write the reply to FD."""
    from kartci.runner.executors import die_with_parent  # executors imports this module

    die_with_parent(os.getppid())
    with os.fdopen(int(sys.argv[1]), "wb") as out:
        path, proj, payload = pickle.load(sys.stdin.buffer)
        sys.path[:] = path
        project.activate(proj)
        try:
            fn, args = pickle.loads(payload)
        except Exception as err:
            out.write(_reply(Reply.CANNOT_LOAD, f"{type(err).__name__}: {err}"))
            return
        try:
            out.write(_reply(Reply.VALUE, fn(*args)))
        except (Exception, SystemExit) as err:
            out.write(_reply(Reply.ERROR, err))
        except KeyboardInterrupt:  # Ctrl-C reached the caller too, which reports it: no trace
            sys.exit(130)


if __name__ == "__main__":
    # by its name, not as __main__: what the child pickles back must name this module
    from kartci.runner import pinned

    pinned.main()
