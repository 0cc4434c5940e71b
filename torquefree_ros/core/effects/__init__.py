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

"""The effects catalogue: every effect behind one interface (:mod:`.base`), in one registry."""

# (importing the modules registers their effects)
from . import actuators, commands, internal, magnetorquers, outputs, sensors, torques  # noqa: F401
from .base import (
    Effect,
    EFFECTS,
    ENERGY,
    invariants_conserved,
    MOMENTUM,
    MotionEffect,
    OutputEffect,
    OutputStream,
    parse_effect,
    remaining_inertia_problem,
)

__all__ = [
    'EFFECTS',
    'ENERGY',
    'MOMENTUM',
    'Effect',
    'MotionEffect',
    'OutputEffect',
    'OutputStream',
    'invariants_conserved',
    'parse_effect',
    'remaining_inertia_problem',
]
