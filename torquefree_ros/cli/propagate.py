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

"""Command-line tools that need no ROS: ``torquefree_propagate`` prints a trajectory as CSV."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .common import console_command
from ..core import make_propagator, PROPAGATORS
from ..core.run.simulation import Simulation
from ..core.timing.grid import sample_count

BLOCK = 1024  # samples computed and printed at a time


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='torquefree_propagate',
        description='Print the torque-free motion of a rigid body as CSV: t, w_x, w_y, w_z (body, '
        'rad/s), q_x, q_y, q_z, q_w (body in inertial).',
    )
    parser.add_argument(
        '--inertia',
        type=float,
        nargs='+',
        default=[3.0, 2.0, 1.0],
        metavar='I',
        help='3 principal moments or 6 tensor elements Ixx Iyy Izz Ixy Ixz Iyz, kg m^2 '
        '(default: 3 2 1)',
    )
    parser.add_argument(
        '--angular-velocity',
        type=float,
        nargs='+',
        default=[0.3, 0.2, 1.0],
        metavar='W',
        help='initial body-frame rates, rad/s (default: 0.3 0.2 1)',
    )
    parser.add_argument(
        '--orientation',
        type=float,
        nargs='+',
        default=[0.0, 0.0, 0.0, 1.0],
        metavar='Q',
        help='initial attitude q_NB as x y z w; normalised when |q|^2 is within 0.01 of 1 '
        '(default: 0 0 0 1)',
    )
    parser.add_argument(
        '--duration',
        type=float,
        default=10.0,
        metavar='SECONDS',
        help='simulated time, s; samples k = 0 ... floor(duration * rate) (default: 10)',
    )
    parser.add_argument(
        '--rate',
        type=float,
        default=10.0,
        metavar='HZ',
        help='samples per second, Hz (default: 10)',
    )
    parser.add_argument(
        '--propagator',
        default='auto',
        choices=['auto', *sorted(PROPAGATORS)],
        help='default: auto (the exact solution)',
    )
    return parser


@console_command('torquefree_propagate')
def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        count = sample_count(args.duration, args.rate)
        simulation = Simulation(
            make_propagator(
                args.inertia, args.angular_velocity, args.orientation, args.propagator
            ),
            args.rate,
        )
    except ValueError as error:
        parser.error(str(error))
    out = sys.stdout
    out.write('t,w_x,w_y,w_z,q_x,q_y,q_z,q_w\n')
    # streamed: memory stays flat and `| head` returns at once
    for first in range(0, count, BLOCK):
        block = simulation.samples(first, min(BLOCK, count - first))
        for row in np.column_stack([block.times, block.omega_B, block.q_NB]).tolist():
            out.write(','.join(map(repr, row)) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
