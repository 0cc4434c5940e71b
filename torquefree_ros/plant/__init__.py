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
The plant: a scene stepped in process by a controller, one body or a batch of thousands.

It runs without DDS (the node's closed loop, MuJoCo's or Gymnasium's step, in this package's
physics). It depends on the core only: scenes, effects and the compiled integrators.
"""

from .plant import Plant, PlantState
from .sensors import PlantSensors, SensorReadings

__all__ = ['Plant', 'PlantSensors', 'PlantState', 'SensorReadings']
