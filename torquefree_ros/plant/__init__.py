"""The plant: a scene stepped in process by a controller, one body or a batch of thousands, without
DDS (the node's closed loop, MuJoCo's or Gymnasium's step, in this package's physics). It depends on the
core only: scenes, effects and the compiled integrators."""

from .plant import Plant, PlantState

__all__ = ["Plant", "PlantState"]
