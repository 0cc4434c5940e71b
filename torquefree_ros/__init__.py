# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
torquefree_ros: an exact torque-free rigid-body attitude simulator for ROS 2.

Importing the package does not import rclpy: the dynamics core is usable without ROS.
"""

from .core import make_propagator, MotionRegime, propagate, propagate_batch, PROPAGATORS, RigidBody
from .core.scene.loader import load_scene, Scene, SceneError
from .plant import Plant, PlantState
from .version import __version__

__all__ = [
    'PROPAGATORS',
    'MotionRegime',
    'Plant',
    'PlantState',
    'RigidBody',
    'Scene',
    'SceneError',
    'load_scene',
    'make_propagator',
    'propagate',
    'propagate_batch',
    '__version__',
]
