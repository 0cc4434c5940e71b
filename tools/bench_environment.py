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
Benchmark of the environment (issue 41): its models per evaluation, and a closed loop on an orbit.

A script, not a test: it prints (and with ``--output`` writes) what it measured and the machine.

- each environment kernel per evaluation: called from a compiled loop (what an integrator's stage
  pays; no Python call in between), and once from Python (what a Python caller pays, numba's
  dispatch included); numpy per point over 10 000 instants (the vectorised reference) and for one
  instant (its fixed cost);
- what an output pays per sample in a closed loop: ``Place.state``, ``Place.field_N``,
  ``Place.position_and_field`` (the two in one compiled call) and ``Place.field_values`` (the
  magnetometer's: its samples in order, computed ``place.AHEAD`` at a time) for one sample from
  Python;
- the library ``bdot_detumble`` scene stepped as a closed loop steps it, one sample at a time at
  10 Hz through ``Simulation.samples(k, 1)``, beside the same body (inertia, initial rates,
  accuracy; no orbit) under a constant body torque stepped the same way, CPU per simulated
  second and the ratio; also the scene without its outputs (what the magnetometer and the
  applied dipole cost), and with the magnetorquers commanded at every sample (the commanded path).
  Each closed-loop call steps a freshly loaded scene; loading it computes the environment's
  first group of windows (``place.GROUP`` windows of ``place.WINDOW`` s), so the windows a long
  run computes as it goes are measured apart: one group of a fresh place, position and field.

Each figure is CPU time (``process_time``: on a shared machine, what the work costs rather than
how long it waited), median (min–max) over ``--rounds`` rounds of the fastest of ``--calls`` calls;
ratios are taken within each round.

Usage: ``.venv/bin/python tools/bench_environment.py [--output docs/bench/environment.md]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import statistics
import sys
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_report import fastest, Report, spread  # noqa: E402
import numpy as np  # noqa: E402
from torquefree_ros.core.environment import earth, epochs, magnetic, sun  # noqa: E402
from torquefree_ros.core.environment import environment_kernels as kernels  # noqa: E402
from torquefree_ros.core.environment.orbit import KeplerOrbit  # noqa: E402

COMPILED_CALLS = 100_000  # kernel evaluations a compiled loop makes per call
PYTHON_CALLS = 10_000  # calls from Python per timed call
INSTANTS = 10_000  # instants of the numpy path's vectorised call
RATE = 10.0  # Hz: the closed loop's sample rate (issue 41)
SCENE = 'bdot_detumble'
#: N m: the reference's constant body torque, of the rods' size (0.2 A m^2 x some 40 uT)
TORQUE = [4.0e-6, -4.0e-6, 4.0e-6]
DIPOLES = 64  # distinct commanded dipoles, cycled one a sample
#: the magnetometer's own per-sample call: its samples in order, computed place.AHEAD at a time
AHEAD_CASE = 'Place.field_values (IGRF-14), samples in order'


def _cpu(function, calls: int) -> float:
    """Return the least CPU seconds of ``calls`` runs of ``function()``."""
    return fastest(function, calls, clock=time.process_time)


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


def kernel_costs(calls: int, loops: dict) -> dict:
    """Return seconds per evaluation of each kernel: compiled loop, from Python, numpy."""
    seconds = epochs.utc_seconds('2026-03-20T12:00:00Z')
    year = float(epochs.decimal_year(seconds))
    table = magnetic.kernel_table()
    orbit = KeplerOrbit(6878137.0, 0.001, 1.7, 0.3, 0.2, 0.1, epoch=seconds)
    orbit_j2 = KeplerOrbit(6878137.0, 0.001, 1.7, 0.3, 0.2, 0.1, epoch=seconds, j2=True)
    position = np.array([6.2e6, 2.1e6, 1.9e6])
    out3, out6, out33 = np.empty(3), np.empty(6), np.empty((3, 3))
    celestial = np.empty((3, 3))
    equation = kernels.celestial_matrix(seconds, celestial)
    n = COMPILED_CALLS
    compiled = [
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
    costs = {}
    for name, loop, arguments in compiled:
        loop(10, *arguments)  # compile or load outside the timing
        costs['compiled', name] = _cpu(lambda: loop(n, *arguments), calls) / n
    row = orbit.kernel_row()
    python_calls = [
        ('orbit', lambda: kernels.kepler_state(0.5, row, out6)),
        ('IGRF-14, Earth-fixed', lambda: kernels.igrf_earth_fixed(*position, year, table, out3)),
        ('IGRF-14, inertial', lambda: kernels.igrf_inertial(position, seconds, table, out3)),
        ('Sun position', lambda: kernels.sun_position(seconds, out3)),
    ]
    for name, call in python_calls:
        call()

        def repeated(call=call):
            for _ in range(PYTHON_CALLS):
                call()

        costs['python', name] = _cpu(repeated, calls) / PYTHON_CALLS
    many = seconds + np.linspace(0.0, 86400.0, INSTANTS)
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
        costs['numpy point', name] = _cpu(lambda: function(many), calls) / many.size
        costs['numpy one', name] = _cpu(lambda: function(seconds), calls)
    return costs


def place_costs(calls: int) -> dict:
    """Return seconds per call of the ``bdot_detumble`` place's per-sample evaluations."""
    from torquefree_ros import load_scene

    place = load_scene(SCENE).orbit
    times = np.array([123.4])  # one sample, as an output's rows of a one-sample block
    position = place.state(times)[0]
    cases = {
        'Place.state': lambda: place.state(times),
        'Place.field_N (IGRF-14)': lambda: place.field_N(times, position, 'igrf'),
        'Place.field_N (dipole)': lambda: place.field_N(times, position, 'dipole'),
        'Place.position_and_field (IGRF-14)': lambda: place.position_and_field(123.4, 'igrf'),
    }
    costs = {}
    for name, call in cases.items():
        call()

        def repeated(call=call):
            for _ in range(PYTHON_CALLS):
                call()

        costs['place', name] = _cpu(repeated, calls) / PYTHON_CALLS

    def in_order():  # a sensor's samples in order: place.AHEAD of them computed a call
        for k in range(PYTHON_CALLS):
            place.field_values(k / RATE, 'igrf', k, RATE)

    costs['place', AHEAD_CASE] = _cpu(in_order, calls) / PYTHON_CALLS
    return costs


def window_costs(calls: int) -> dict:
    """
    Return the CPU seconds of one group of environment windows past a fresh place's first.

    What a run of ``bdot_detumble`` computes each ``GROUP`` windows: the orbit's positions at the
    windows' Chebyshev points and the IGRF-14 field there.
    """
    from torquefree_ros import load_scene
    from torquefree_ros.core.environment import place as place_module

    places = [load_scene(SCENE).orbit for _ in range(calls)]
    window = place_module.GROUP  # the first window of the second group
    field = place_module.QUANTITIES.index('igrf')
    best = min(
        _cpu(lambda place=place: place.chebyshev(window, field), 1)  # positions, then field
        for place in places
    )
    span = place_module.GROUP * place_module.WINDOW
    return {('windows', 'group'): best, ('windows', 'per second'): best / span}


def reference_scene(scene, outputs: bool = False):
    """
    Return the same body as ``scene`` (no orbit) under a constant body torque.

    ``outputs``: with two outputs that need no environment (an exact ``imu`` and the ``pose``),
    what a sample's outputs cost without the environment.
    """
    from torquefree_ros.core.scene.loader import scene_from_mapping

    return scene_from_mapping(
        {
            'body': {'inertia': np.asarray(scene.inertia, dtype=float).tolist()},
            'initial': {
                'angular_velocity': np.asarray(scene.angular_velocity, dtype=float).tolist(),
                'orientation': np.asarray(scene.orientation, dtype=float).tolist(),
            },
            'effects': [
                {'external_torque': {'torque': list(TORQUE)}},
                *([{'imu': {}}, {'pose': {}}] if outputs else []),
            ],
            'accuracy': float(scene.accuracy),
        },
        '<bench: constant torque>',
    )


def stepped(case: str, span: float) -> float:
    """
    Return the CPU seconds per simulated second of ``case`` stepped one sample at a time.

    ``case``: ``torque`` (the reference), ``torque_outputs`` (the reference with an ``imu`` and a
    ``pose``), ``bdot`` (the library scene with its outputs), ``magnetometer`` (with its
    magnetometer only), ``dipole_output`` (with its ``magnetorquer_dipole`` output only), ``bare``
    (without its outputs), ``commanded`` (with its outputs, a dipole
    offered to the magnetorquers' hold before every sample, as a controller answering each sample
    would).
    """
    from torquefree_ros import load_scene
    from torquefree_ros.core.run.simulation import Simulation

    scene = load_scene(SCENE)  # fresh: no windows past the first group, no commands held
    if case.startswith('torque'):
        scene = reference_scene(scene, outputs=case == 'torque_outputs')
    outputs = {
        'torque_outputs': scene.outputs, 'bdot': scene.outputs, 'commanded': scene.outputs,
        'magnetometer': tuple(o for o in scene.outputs if o.name == 'magnetometer'),
        'dipole_output': tuple(o for o in scene.outputs if o.name == 'magnetorquer_dipole'),
    }.get(case, ())
    simulation = Simulation(scene.propagator(), RATE, outputs=outputs)
    dipoles = None
    if case == 'commanded':
        ((effect, hold),) = simulation.command_holds
        hold.frame_id = 'body'
        dipoles = np.random.default_rng(41).uniform(-0.2, 0.2, (DIPOLES, 3)).tolist()
    steps = int(round(span * RATE))
    started = time.process_time()
    for k in range(steps):
        if dipoles is not None:
            accepted, reason = effect.receive(simulation.stamp_ns(k), 'body', dipoles[k % DIPOLES])
            if not accepted:
                raise RuntimeError(f'the command of sample {k} was refused: {reason}')
        simulation.samples(k, 1)
    return (time.process_time() - started) / span


CLOSED_LOOP_CASES = (
    'torque', 'torque_outputs', 'bdot', 'magnetometer', 'dipole_output', 'bare', 'commanded'
)


def closed_loop_costs(calls: int, span: float) -> dict:
    """Return CPU seconds per simulated second of each closed-loop case, interleaved by call."""
    best = dict.fromkeys(CLOSED_LOOP_CASES, float('inf'))
    for _ in range(calls):  # interleaved, so that a noisy moment hits every case alike
        for case in CLOSED_LOOP_CASES:
            best[case] = min(best[case], stepped(case, span))
    return {('loop', case): value for case, value in best.items()}


def measure_round(calls: int, span: float, loops: dict) -> dict:
    costs = kernel_costs(calls, loops)
    costs.update(place_costs(calls))
    costs.update(window_costs(calls))
    costs.update(closed_loop_costs(calls, span))
    torque = costs['loop', 'torque']
    for case in CLOSED_LOOP_CASES[1:]:
        costs['ratio', case] = costs['loop', case] / torque
    return costs


def _met(value: float, target: float) -> str:
    return 'yes' if value <= target else '**no**'


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--output', help='write the report here (Markdown)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--calls', type=int, default=3)
    parser.add_argument(
        '--span', type=float, default=960.0,
        help='simulated seconds of each closed-loop call (default: 960, one group of windows)',
    )
    args = parser.parse_args(argv)

    import numba

    from torquefree_ros.core.environment import place as place_module

    report = Report('The environment: its models, and a closed loop on an orbit',
                    'make bench-environment')
    report.add(f'- versions: numpy {np.__version__}, numba {numba.__version__}')
    report.add('')
    report.add(
        f'{args.rounds} rounds; each figure is median (min–max) over the rounds of the fastest of '
        f'{args.calls} calls, CPU time (`process_time`); ratios are taken within each round. '
        'The machine was loaded while this ran (a test suite and another benchmark in a loop on '
        'both cores): the CPU times are what the work costs, the ratios measured side by side '
        'are the figures to compare.'
    )
    report.add('')
    loops = compiled_loops()
    stepped('bdot', 1.0)  # compile or load every kernel of the closed loops outside the timing
    stepped('torque', 1.0)
    rounds = [measure_round(args.calls, args.span, loops) for _ in range(args.rounds)]

    def column(key, scale=1.0):
        return spread([r[key] * scale for r in rounds])

    def median(key):
        return statistics.median(r[key] for r in rounds)

    steps = int(round(args.span * RATE))
    report.add('| measure | value | target (issue 41) | met |')
    report.add('|---|---|---|---|')
    kepler = ('compiled', 'orbit (Kepler, no J2)')
    report.add(
        '| orbit position and velocity, Kepler closed form, per sample (compiled loop) | '
        f'{column(kepler, 1e6)} µs | ≤ 0.2 µs | {_met(median(kepler), 0.2e-6)} |'
    )
    kepler_j2 = ('compiled', 'orbit (Kepler, J2 drift)')
    report.add(
        f"| the same with J2's secular drift | {column(kepler_j2, 1e6)} µs | ≤ 0.2 µs | "
        f'{_met(median(kepler_j2), 0.2e-6)} |'
    )
    igrf = ('compiled', 'IGRF-14, inertial (full W)')
    report.add(
        '| magnetic field, IGRF-14 degree 13 in the inertial frame (Earth rotation, precession '
        f'and nutation at the instant), per sample (compiled loop) | {column(igrf, 1e6)} µs | '
        f'≤ 2 µs | {_met(median(igrf), 2e-6)} |'
    )
    report.add(
        f'| closed loop, {RATE:g} Hz, one sample a `Simulation.samples(k, 1)` over '
        f'{args.span:g} s: the same body (no orbit) under a constant body torque, CPU per '
        f'simulated second | {column(("loop", "torque"), 1e6)} µs | | |'
    )
    report.add(
        f'| `{SCENE}` (magnetometer and applied dipole outputs, rods uncommanded), CPU per '
        f'simulated second | {column(("loop", "bdot"), 1e6)} µs, '
        f'{column(("ratio", "bdot"))} x the torque | ≤ 3x | {_met(median(("ratio", "bdot")), 3)} |'
    )
    report.add(
        f'| `{SCENE}` with a dipole commanded before every sample | '
        f'{column(("loop", "commanded"), 1e6)} µs, {column(("ratio", "commanded"))} x the torque '
        f'| ≤ 3x | {_met(median(("ratio", "commanded")), 3)} |'
    )
    report.add(
        f'| `{SCENE}` without its outputs (what the magnetometer and the applied dipole cost) | '
        f'{column(("loop", "bare"), 1e6)} µs, {column(("ratio", "bare"))} x the torque | | |'
    )
    report.add(
        f'| `{SCENE}` with its magnetometer only | {column(("loop", "magnetometer"), 1e6)} µs, '
        f'{column(("ratio", "magnetometer"))} x the torque | | |'
    )
    report.add(
        f'| `{SCENE}` with its applied dipole output (`magnetorquer_dipole`) only | '
        f'{column(("loop", "dipole_output"), 1e6)} µs, {column(("ratio", "dipole_output"))} x '
        'the torque | | |'
    )
    report.add(
        '| the constant-torque body with two outputs that need no environment (an exact `imu` '
        f'and the `pose`) | {column(("loop", "torque_outputs"), 1e6)} µs, '
        f'{column(("ratio", "torque_outputs"))} x the torque | | |'
    )
    report.add(
        '| the detumble campaign (1 000 runs x 3 orbits) with the default engine | not measured: '
        'a campaign runs its plant open loop (`Plant.run`), no controller answers its samples '
        'with a dipole, and the campaign library has no detumble campaign | ≤ 10 min | — |'
    )
    report.add('')
    report.add(
        f'The closed loop: each call loads `{SCENE}` afresh and steps {steps:,} samples. Loading '
        "computes the environment's first group of windows, so the groups a longer run computes "
        f'as it goes ({place_module.GROUP} windows of {place_module.WINDOW:g} s at a time: '
        'position and IGRF-14 field at their Chebyshev points) are measured apart: '
        f'{column(("windows", "group"), 1e3)} ms a group, '
        f'{column(("windows", "per second"), 1e6)} µs per simulated second. The reference is '
        "the scene's body (inertia, initial rates and orientation, accuracy) with "
        f'`external_torque` {TORQUE} N m and no orbit. Commanded: one of {DIPOLES} seeded '
        "dipoles in ±0.2 A m² offered to the magnetorquers' hold (`Magnetorquers.receive`, "
        "stamped at the sample) before every sample; a controller's own work is not included."
    )
    report.add('')
    report.add(
        'What an output pays per sample in a closed loop (one sample from Python). The '
        "magnetometer takes the orbit's position and the field in one compiled call "
        '(`Place.position_and_field`: the floats of `Place.state` and `Place.field_N`); with its '
        f'samples in order (`Place.field_values`) those of the next {place_module.AHEAD} samples '
        'in one call, kept:'
    )
    report.add('')
    report.add('| call | µs a sample |')
    report.add('|---|---|')
    for name in ('Place.state', 'Place.field_N (IGRF-14)', 'Place.field_N (dipole)',
                 'Place.position_and_field (IGRF-14)', AHEAD_CASE):
        report.add(f'| `{name}` | {column(("place", name), 1e6)} |')
    report.add('')
    report.add('Each kernel per evaluation: inside a compiled loop of '
               f"{COMPILED_CALLS:,} evaluations, and one call from Python (numba's dispatch "
               'included):')
    report.add('')
    report.add('| kernel | compiled loop, µs | from Python, µs |')
    report.add('|---|---|---|')
    from_python = {
        'orbit (Kepler, no J2)': 'orbit', 'IGRF-14, Earth-fixed': 'IGRF-14, Earth-fixed',
        'IGRF-14, inertial (full W)': 'IGRF-14, inertial', 'Sun position': 'Sun position',
    }
    for key in rounds[0]:
        if key[0] != 'compiled':
            continue
        name = key[1]
        python = from_python.get(name)
        report.add(
            f'| {name} | {column(key, 1e6)} | '
            f'{column(("python", python), 1e6) if python else ""} |'
        )
    report.add('')
    report.add(f'numpy (the reference path): per point of a call over {INSTANTS:,} instants, '
               'and one call for one instant:')
    report.add('')
    report.add('| model | µs a point | µs for one instant |')
    report.add('|---|---|---|')
    for key in rounds[0]:
        if key[0] == 'numpy point':
            name = key[1]
            report.add(
                f'| {name} | {column(key, 1e6)} | {column(("numpy one", name), 1e6)} |'
            )
    report.save(args.output)
    return 0


if __name__ == '__main__':
    sys.exit(main())
