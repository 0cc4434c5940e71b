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
The work-precision report (``torquefree_bench``): what each propagator's accuracy costs in time.

The accuracy is measured against the high-precision reference solutions of the hard cases, beside
scipy's ``solve_ivp`` and (when importable) MuJoCo's RK4 free body, with the cost of the effects
and of the ROS layer per sample. A measuring tool, not part of the simulator: the node never
imports it.
"""
