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
The exact torque-free solution (seed 000).

The rates as Jacobi elliptic functions and the attitude as a rotation about the constant inertial
momentum:

- :mod:`.elliptic`: Jacobi sn/cn/dn and the elliptic integrals, on the complementary parameter.
- :mod:`.polhode` and :mod:`.polhode_constants`: a body's polhode and the attitude's constants;
  :mod:`.regime`: the kind of motion (``MotionRegime``).
- :mod:`.attitude_kernels`: the same evaluation compiled by numba (one family of kernels).
- :mod:`.gyrostat`: the free gyrostat with its rotor along a principal axis, the same way;
  :mod:`.gyrostat_kernels`: its evaluation compiled (a family of its own).
- :mod:`.gyrostat_oblique`: the free gyrostat with ``h`` off every principal axis (Weierstrass's
  solution on the momentum sphere); :mod:`.gyrostat_oblique_kernels`: its evaluation compiled.

Works on principal moments and rates, not on a body object. May import: :mod:`..numerics`,
:mod:`..timing`, :mod:`..checks`, :mod:`..frames`.
"""
