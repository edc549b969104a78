"""Agents: controllers and input sources. They read and publish messages, never sim state.
Which class runs for `controller: {type: NAME}` is the controller registry's answer."""

from __future__ import annotations

from kartci.core import Agent, Outbox

__all__ = ["Agent", "Outbox"]
