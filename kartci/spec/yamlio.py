"""Deprecated: `kartci.scenario.yamlio`."""

from kartci.scenario.yamlio import *  # noqa: F403
