"""Command-line tools that need no ROS: ``torquefree_propagate`` prints a trajectory as CSV."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from .core import PROPAGATORS, make_propagator
from .core.timing import sample_times


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="torquefree_propagate",
        description="Print the torque-free motion of a rigid body as CSV: t, w_x, w_y, w_z (body, rad/s), "
        "q_x, q_y, q_z, q_w (body in inertial).",
    )
    parser.add_argument("--inertia", type=float, nargs="+", default=[3.0, 2.0, 1.0],
                        help="3 principal moments or 6 tensor elements Ixx Iyy Izz Ixy Ixz Iyz (kg m^2)")
    parser.add_argument("--angular-velocity", type=float, nargs="+", default=[0.3, 0.2, 1.0],
                        help="initial body rates (rad/s)")
    parser.add_argument("--orientation", type=float, nargs="+", default=[0.0, 0.0, 0.0, 1.0],
                        help="initial attitude x y z w")
    parser.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    parser.add_argument("--rate", type=float, default=10.0, help="samples per second (default 10)")
    parser.add_argument("--propagator", default="auto", choices=["auto", *sorted(PROPAGATORS)])
    return parser


def propagate_main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        times = sample_times(args.duration, args.rate)
        propagator = make_propagator(args.inertia, args.angular_velocity, args.orientation, args.propagator)
    except ValueError as error:
        parser.error(str(error))
    omega, q = propagator(times)
    out = sys.stdout
    out.write("t,w_x,w_y,w_z,q_x,q_y,q_z,q_w\n")
    for row in np.column_stack([times, omega, q]):
        out.write(",".join(repr(float(x)) for x in row) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(propagate_main())
