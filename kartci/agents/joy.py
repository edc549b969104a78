"""Deprecated: import from `kartci.robots.gokart.joy` (joystick mappings are the kart's).
Kept so that code written against `kartci.agents.joy` keeps working; nothing in kartci imports
it."""

from kartci.robots.gokart.joy import (
    Button,
    JoyMapping,
    PedalAxis,
    SteeringAxis,
    check_counts,
    check_pad,
    kart_command,
    known_mappings,
    load_mapping,
    to_command,
    to_joy,
)

__all__ = ["Button", "JoyMapping", "PedalAxis", "SteeringAxis", "check_counts", "check_pad",
           "kart_command", "known_mappings", "load_mapping", "to_command", "to_joy"]
