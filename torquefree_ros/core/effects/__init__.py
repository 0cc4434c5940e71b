"""The effects catalogue: every effect behind one interface (:mod:`.base`), in one registry."""

from . import commands, internal, outputs, torques  # noqa: F401  (registers the effects)
from .base import (EFFECTS, ENERGY, MOMENTUM, Effect, MotionEffect, OutputEffect, OutputStream,
                   invariants_conserved, parse_effect)

__all__ = ["EFFECTS", "ENERGY", "MOMENTUM", "Effect", "MotionEffect", "OutputEffect", "OutputStream",
           "invariants_conserved", "parse_effect"]
