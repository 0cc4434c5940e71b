#!/usr/bin/env python3
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
What one evaluation of each environment model costs: compiled kernels and the numpy path.

A script, not a test: it prints what it measured and the machine. Compiled: the kernel called
from a compiled loop (what an integrator's stage pays; no Python call in between), and once from
Python (what a Python caller pays, numba's dispatch included). numpy: per point over 10 000
instants (the vectorised reference) and for one instant (its fixed cost). Best of 5 rounds.

Usage: ``.venv/bin/python tools/bench_environment.py``.
"""

from __future__ import annotations

import os
import platform
import time

import numpy as np
from torquefree_ros.core.environment import earth, epochs, magnetic, sun
from torquefree_ros.core.environment import environment_kernels as kernels
from torquefree_ros.core.environment.orbit import KeplerOrbit

ROUNDS = 5


def best(function, repeat: int) -> float:
    """Return the least seconds per call of ``function`` over :data:`ROUNDS` rounds."""
    times = []
    for _ in range(ROUNDS):
        start = time.perf_counter()
        function()
        times.append((time.perf_counter() - start) / repeat)
    return min(times)


def compiled_loops():
    """Build numba loops that call each kernel ``n`` times from compiled code."""
    import numba

    kernels.compile_kernels()
    kepler_state = kernels.kepler_state
    earth_fixed_matrix = kernels.earth_fixed_matrix
    earth_fixed_matrix_held = kernels.earth_fixed_matrix_held
    igrf_earth_fixed = kernels.igrf_earth_fixed
    igrf_inertial = kernels.igrf_inertial
    field_inertial_with = kernels.field_inertial_with
    dipole_inertial = kernels.dipole_inertial
    sun_position = kernels.sun_position
    shadow_fraction = kernels.shadow_fraction

    @numba.njit
    def kepler(n, row, out):
        for i in range(n):
            kepler_state(i * 0.37, row, out)

    @numba.njit
    def frame(n, seconds, out):
        for i in range(n):
            earth_fixed_matrix(seconds + i * 0.1, out)

    @numba.njit
    def frame_held(n, seconds, celestial, equation, out):
        for i in range(n):
            earth_fixed_matrix_held(seconds + i * 0.1, celestial, equation, out)

    @numba.njit
    def igrf_fixed(n, position, year, table, out):
        for i in range(n):
            igrf_earth_fixed(position[0] + i * 1e-3, position[1], position[2], year, table, out)

    @numba.njit
    def igrf_full(n, position, seconds, table, out):
        for i in range(n):
            igrf_inertial(position, seconds + i * 0.1, table, out)

    @numba.njit
    def igrf_held(n, position, seconds, celestial, equation, year, table, out):
        matrix = np.empty((3, 3))
        for i in range(n):
            earth_fixed_matrix_held(seconds + i * 0.1, celestial, equation, matrix)
            field_inertial_with(0, position, matrix, year, table, out)

    @numba.njit
    def dipole_full(n, position, seconds, table, out):
        for i in range(n):
            dipole_inertial(position, seconds + i * 0.1, table, out)

    @numba.njit
    def sun_loop(n, seconds, out):
        for i in range(n):
            sun_position(seconds + i * 0.1, out)

    @numba.njit
    def shadow(n, position, sun_at):
        total = 0.0
        for i in range(n):
            position[0] += 1e-3
            total += shadow_fraction(position, sun_at)
        return total

    return {
        'kepler': kepler, 'frame': frame, 'frame_held': frame_held, 'igrf_fixed': igrf_fixed,
        'igrf_full': igrf_full, 'igrf_held': igrf_held, 'dipole_full': dipole_full,
        'sun': sun_loop, 'shadow': shadow,
    }


def main() -> int:
    seconds = epochs.utc_seconds('2026-03-20T12:00:00Z')
    year = float(epochs.decimal_year(seconds))
    table = magnetic.kernel_table()
    orbit = KeplerOrbit(6878137.0, 0.001, 1.7, 0.3, 0.2, 0.1, epoch=seconds)
    orbit_j2 = KeplerOrbit(6878137.0, 0.001, 1.7, 0.3, 0.2, 0.1, epoch=seconds, j2=True)
    position = np.array([6.2e6, 2.1e6, 1.9e6])
    out3, out6, out33 = np.empty(3), np.empty(6), np.empty((3, 3))
    print(f'machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, '
          f'Python {platform.python_version()}, numpy {np.__version__}')
    loops = compiled_loops()
    celestial = np.empty((3, 3))
    equation = kernels.celestial_matrix(seconds, celestial)
    n = 100_000
    cases = [
        ('orbit (Kepler, no J2)', loops['kepler'], (orbit.kernel_row(), out6)),
        ('orbit (Kepler, J2 drift)', loops['kepler'], (orbit_j2.kernel_row(), out6)),
        ('Earth-fixed matrix W (full)', loops['frame'], (seconds, out33)),
        ('Earth-fixed matrix W (N P held)', loops['frame_held'],
         (seconds, celestial, equation, out33)),
        ('IGRF-14, Earth-fixed', loops['igrf_fixed'], (position, year, table, out3)),
        ('IGRF-14, inertial (full W)', loops['igrf_full'], (position, seconds, table, out3)),
        ('IGRF-14, inertial (N P held)', loops['igrf_held'],
         (position, seconds, celestial, equation, year, table, out3)),
        ('dipole, inertial (full W)', loops['dipole_full'], (position, seconds, table, out3)),
        ('Sun position', loops['sun'], (seconds, out3)),
        ('shadow fraction', loops['shadow'], (position.copy(), sun.sun_position(seconds))),
    ]
    print('\ncompiled, per evaluation inside a compiled loop:')
    for name, loop, arguments in cases:
        loop(10, *arguments)
        print(f'  {name:34s} {best(lambda: loop(n, *arguments), n) * 1e9:8.0f} ns')
    print('\ncompiled, one call from Python (numba dispatch included):')
    row = orbit.kernel_row()
    python_calls = [
        ('orbit', lambda: kernels.kepler_state(0.5, row, out6)),
        ('IGRF-14, Earth-fixed', lambda: kernels.igrf_earth_fixed(*position, year, table, out3)),
        ('IGRF-14, inertial', lambda: kernels.igrf_inertial(position, seconds, table, out3)),
        ('Sun position', lambda: kernels.sun_position(seconds, out3)),
    ]
    for name, call in python_calls:
        call()
        cost = best(lambda: [call() for _ in range(10_000)], 10_000)
        print(f'  {name:34s} {cost * 1e6:8.2f} µs')
    print('\nnumpy (the reference path): per point over 10 000 instants, and one instant')
    many = seconds + np.linspace(0.0, 86400.0, 10_000)
    positions = orbit.position(many - seconds)
    fixed = earth.to_earth_fixed(positions, many)
    numpy_cases = [
        ('orbit (Kepler)', lambda s: orbit.state(s - seconds)),
        ('Earth-fixed matrix W', earth.earth_fixed_matrix),
        ('IGRF-14, Earth-fixed', lambda s: magnetic.igrf_earth_fixed(
            fixed[:np.size(s)] if np.ndim(s) else fixed[0], s)),
        ('IGRF-14, inertial', lambda s: magnetic.igrf_inertial(
            positions[:np.size(s)] if np.ndim(s) else positions[0], s)),
        ('Sun position', sun.sun_position),
    ]
    for name, function in numpy_cases:
        per_point = best(lambda: function(many), 1) / many.size
        single = best(lambda: function(seconds), 1)
        print(f'  {name:34s} {per_point * 1e6:8.2f} µs a point, {single * 1e6:8.0f} µs for one')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
