"""Deprecated: `kartci.scenario.models`."""

from kartci.scenario.models import *  # noqa: F403
