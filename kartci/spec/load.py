"""Deprecated: `kartci.scenario.load`."""

from kartci.scenario.load import *  # noqa: F403
