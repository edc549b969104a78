"""Deprecated: import from `kartci.core` (`Agent`, `Outbox`).

Kept so that plugins written against `kartci.agents.base` keep working; nothing in kartci
imports it."""

from kartci.core.agent import Agent, Outbox

__all__ = ["Agent", "Outbox"]
