"""Which bridge serves `controller: {type: external}`: its `middleware` setting chooses."""

from __future__ import annotations

from kartci.bridge.agent import ExternalAgent
from kartci.bridge.dds.agent import DdsAgent
from kartci.bridge.params import ExternalController
from kartci.core import AgentContext


def external_agent(spec: ExternalController, ctx: AgentContext) -> ExternalAgent:
    """Zenoh (kartci's own session) or DDS (a relay under a ROS 2 Python)."""
    return DdsAgent(spec, ctx) if spec.middleware == "dds" else ExternalAgent(spec, ctx)
