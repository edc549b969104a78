"""Deprecated: `kartci.scenario.dispatch`."""

from kartci.scenario.dispatch import *  # noqa: F403
