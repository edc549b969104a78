"""Model predictive contouring control for the go-kart: model, NLP, compiled-solver cache,
per-stage references with obstacles, and the solve loop."""

from kartci.robots.gokart.mpcc.controller import Mpcc, Plan
from kartci.robots.gokart.mpcc.reference import Obstacle, obstacle_from_xy

__all__ = ["Mpcc", "Obstacle", "Plan", "obstacle_from_xy"]
