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
What each effect adds to a step, and what each output adds to a sample.

The price of the third promise (a scene computes only the effects it names).
"""

from __future__ import annotations

import timeit

import numpy as np

from ..core.effects import parse_effect
from ..core.propagators import make_propagator

BODY = ([3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [0.0, 0.0, 0.0, 1.0])
#: one typical configuration per motion effect
MOTION_EFFECTS = {
    'external_torque (body frame)': {'external_torque': {'torque': [1e-3, 0.0, 2e-3]}},
    'external_torque (inertial frame)': {
        'external_torque': {'torque': [1e-3, 0.0, 2e-3], 'frame': 'inertial'}
    },
    'gravity_gradient': {'gravity_gradient': {'mean_motion': 1.1e-3}},
    'damper': {'damper': {'inertia': 0.1, 'damping': 0.05}},
    'rotor': {'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 1.0]}},
}
OUTPUTS = {
    'imu': {'imu': {'gyro_noise_density': 1e-4, 'gyro_bias_random_walk': 1e-5, 'seed': 1}},
    'euler_angles': {'euler_angles': {}},
}
_BLOCK = 256  # samples per output call, as the node's loop


def _best_us(call, number: int) -> float:
    return min(timeit.repeat(call, number=number, repeat=5)) / number * 1e6


def motion_effect_costs(number: int = 2000) -> list[dict]:
    """
    Measure each motion effect's cost: µs per right-hand-side evaluation and per RK4 step.

    Per effect: µs per right-hand-side evaluation and per RK4 step (4 evaluations), and what each
    adds to the torque-free baseline (first row).
    """
    rows = []
    base = None
    for label, entry in {'torque-free (no effect)': None, **MOTION_EFFECTS}.items():
        effects = () if entry is None else (parse_effect(entry, 'effects[0]'),)
        propagator = make_propagator(*BODY, 'rk4', effects=effects, step=1e-2)
        y = np.concatenate([propagator.omega0_B, propagator.q0_NB, propagator.x0])
        derivative = _best_us(lambda: propagator.dynamics.derivative(0.5, y, 0.0), number)
        step = _best_us(lambda: propagator.advance(0.5, y, 1e-2), number // 4)
        if base is None:
            base = (derivative, step)
        rows.append(
            {
                'effect': label,
                'rhs_us': derivative,
                'rk4_step_us': step,
                'added_rhs_us': derivative - base[0],
                'added_step_us': step - base[1],
            }
        )
    return rows


def output_costs(number: int = 20) -> list[dict]:
    """Per output effect: µs per sample, computed for blocks of 256 samples at 100 Hz."""
    times = np.arange(_BLOCK) / 100.0
    propagator = make_propagator(*BODY)
    omega, q = propagator(times)
    internal = np.empty((_BLOCK, 0))
    rows = []
    for label, entry in OUTPUTS.items():
        stream = parse_effect(entry, 'effects[0]').stream(100.0, propagator)
        # fresh sample indices: a stream consumes its noise in order
        first = iter(range(0, 10**9, _BLOCK))
        cost = (
            _best_us(lambda: stream.rows(next(first), times, omega, q, internal), number) / _BLOCK
        )
        rows.append({'output': label, 'us_per_sample': cost})
    return rows
