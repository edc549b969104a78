"""Deprecated: `kartci.scenario.schema`."""

from kartci.scenario.schema import *  # noqa: F403
