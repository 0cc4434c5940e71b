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
Numerical integration at compiled speed: the kernels that integrate a scene with effects.

- :mod:`.motion_kernels`: the equations of motion (every motion effect's torque and state rate) and
  the steps of DOP853 (scipy's tableau, error control and dense output), RK4 and Lie-group RK4, as
  numba-compiled scalar loops that allocate nothing per step.
- :mod:`.compiled`: a scene's dynamics packed for them, and the drivers the propagators
  (``core/propagators/numerical.py``, the reference path with scipy and numpy) hand their
  evaluation to when numba is present and ``TORQUEFREE_ROS_KERNELS`` is not ``numpy``.

Each effect is defined once in ``core/effects`` (its Python torque, the reference) and names its
kernel here by code; test_motion_kernels.py holds every effect's two forms together on random
states, and the compiled propagators against the reference ones and against closed forms.
"""
