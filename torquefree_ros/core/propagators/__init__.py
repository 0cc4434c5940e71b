"""Propagator registry: every propagator behind one interface, looked up by name."""

from . import analytic, numerical  # noqa: F401  (registers the propagators)
from .base import PROPAGATORS, Propagator, propagator_class

__all__ = ["PROPAGATORS", "Propagator", "propagator_class", "make_propagator"]


def make_propagator(body, angular_velocity, orientation, propagator: str = "auto", **options) -> Propagator:
    """Build a propagator by name; ``auto`` is the exact one for a torque-free body."""
    name = "analytic" if propagator == "auto" else propagator
    return propagator_class(name)(body, angular_velocity, orientation, **options)
