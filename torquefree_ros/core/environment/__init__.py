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
Where the body is: its orbit, the Earth's orientation and magnetic field, the Sun and its shadow.

Pure functions of time, with no state and no ROS; each model cites its source and states its
accuracy. Time is UTC seconds since J2000.0 (2000-01-01T12:00:00 UTC) counted in days of 86 400
s (:mod:`.epochs`); an orbit's own time is seconds since its epoch. Vectors are SI (m, m/s, T).

- :mod:`.epochs`: UTC instants, the time scales and the decimal year the models read.
- :mod:`.earth`: the Earth's constants, the inertial frame (EME2000: the mean equator and equinox
  of J2000.0) and its rotation into the Earth-fixed frame and from SGP4's TEME.
- :mod:`.orbit`: Keplerian elements (exact two-body motion, optional J2 secular drift);
  :mod:`.tle`: a two-line element set propagated by SGP4 (the ``sgp4`` package).
- :mod:`.magnetic`: IGRF-14 (:mod:`.igrf14_coefficients`, the released table) and the tilted
  dipole.
- :mod:`.sun`: a low-precision solar ephemeris and the Earth's shadow (umbra and penumbra).
- :mod:`.environment_kernels`: the same models as scalar numba kernels (one family of kernels),
  for integrators that evaluate them at every stage.
- :mod:`.place`: a scene's ``orbit:`` section (an orbit and the UTC instant of the scene's ``t =
  0``), the environment at sample times, and held per 60 s window as Chebyshev interpolants for
  the integrators (the numbers the motion kernels read).

Every function takes arrays of times (vectorised numpy: the reference path); the kernels take one
time and are held to it in the tests. May import: :mod:`..numerics`, :mod:`..checks`, numpy and
``sgp4`` (lazily, in :mod:`.tle`).
"""
