"""Deprecated: import from `kartci.core` (the contracts and the registries); `ScoreContext`
from `kartci.metrics`.

The public path plugin authors use (docs/howto/plugins.md, docs/tutorial.md, examples/): every
name here is `kartci.core`'s own object (`kartci.core.__all__`, the one list of them), so
registering through either path is the same. Nothing in kartci imports this module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from kartci.core import *  # noqa: F403  (every name of kartci.core.__all__)
from kartci.core import __all__ as _core_names

if TYPE_CHECKING:
    from kartci.metrics import ScoreContext

__all__ = [*_core_names, "ScoreContext"]


def __getattr__(name: str) -> Any:
    """`ScoreContext` (what a metric set's `compute` is given) without importing pandas here."""
    if name == "ScoreContext":
        # start-up: kartci.metrics brings pandas and the log readers (+0.7 s)
        from kartci.metrics import ScoreContext

        return ScoreContext
    raise AttributeError(f"module 'kartci.plugins' has no attribute '{name}'")
