"""torquefree_ros: an exact torque-free rigid-body attitude simulator for ROS 2.

Importing the package does not import rclpy: the dynamics core is usable without ROS.
"""

from .core import PROPAGATORS, MotionRegime, RigidBody, make_propagator, propagate, propagate_batch
from .core.scene import Scene, SceneError, load_scene
from .plant import Plant, PlantState

__version__ = "0.1.0"
__all__ = ["PROPAGATORS", "MotionRegime", "Plant", "PlantState", "RigidBody", "Scene", "SceneError", "load_scene",
           "make_propagator", "propagate", "propagate_batch", "__version__"]
