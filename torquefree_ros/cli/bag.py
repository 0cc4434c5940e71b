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
``torquefree_bag``: a scene simulated offline, as fast as possible, into a rosbag2 MCAP bag.

The simulation is ``bag.offline``'s; ``--reindex BAG`` makes a bag whose recorder died complete
again.
"""

from __future__ import annotations

import argparse
from decimal import Decimal, InvalidOperation
import math
import sys
import time

from .common import console_command, GracefulStop, INTERRUPTED, Progress
from ..bag import BagError, reindex
from ..bag.offline import write_scene_bag
from ..bag.writer import COMPRESSIONS
from ..core import PROPAGATORS
from ..core.scene.library import library_scenes
from ..core.scene.loader import load_scene, SceneError


def _seconds(text: str) -> Decimal:
    # the wall clock, to the nanosecond: viewers then show today rather than 1970
    if text == 'now':
        return Decimal(time.time_ns()) / 10**9
    try:
        return Decimal(text)
    except InvalidOperation:
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds or 'now', got {text!r}"
        ) from None


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='torquefree_bag',
        usage='torquefree_bag SCENE --duration SECONDS --rate HZ --output BAG_DIR [options]\n'
        '       torquefree_bag --reindex BAG_DIR',
        description='Simulate a scene offline, as fast as possible, into a rosbag2 (Jazzy) MCAP '
        'bag: angular_velocity (Vector3Stamped), attitude (QuaternionStamped) and the outputs the '
        'scene names, samples k = 0 ... floor(duration * rate), both ends included, the bytes the '
        'node would publish. An energy sweep writes every member, member j under '
        'NAMESPACE/member_j.',
        epilog='library scenes: ' + ', '.join(sorted(library_scenes())),
    )
    required = parser.add_argument_group('required (unless --reindex)')
    required.add_argument(
        'scene',
        nargs='?',
        metavar='SCENE',
        help='a scene file (YAML) or the name of a library scene',
    )
    required.add_argument('--duration', type=float, metavar='SECONDS', help='simulated time, s')
    required.add_argument(
        '--rate', type=float, metavar='HZ', help='samples per simulated second, Hz'
    )
    required.add_argument(
        '--output',
        metavar='BAG_DIR',
        help='bag directory to create (its parent directories are created too)',
    )
    options = parser.add_argument_group('options')
    options.add_argument(
        '--overwrite', action='store_true', help='replace an existing bag directory (only a bag)'
    )
    options.add_argument(
        '--compression',
        choices=sorted(COMPRESSIONS),
        default='none',
        help='MCAP chunk compression (default: none, like rosbag2)',
    )
    options.add_argument(
        '--start-time',
        type=_seconds,
        default=Decimal(0),
        metavar='SECONDS',
        help="stamp of sample 0, s since the epoch, read to the nanosecond, or 'now' (the wall "
        'clock: viewers then date the bag today rather than 1970, and each run writes other '
        'stamps) (default: 0)',
    )
    options.add_argument(
        '--propagator',
        default='auto',
        choices=['auto', *sorted(PROPAGATORS)],
        help='default: auto (the exact solution unless an effect changes the motion)',
    )
    options.add_argument(
        '--body-frame',
        default='body',
        metavar='FRAME',
        help='header.frame_id of angular_velocity (default: body)',
    )
    options.add_argument(
        '--inertial-frame',
        default='world',
        metavar='FRAME',
        help='header.frame_id of attitude (default: world)',
    )
    options.add_argument('--namespace', default='/', help='namespace of the topics (default: /)')
    options.add_argument(
        '--position',
        type=float,
        nargs=3,
        metavar=('X', 'Y', 'Z'),
        help="where tf, pose, odometry and markers place the body's centre in the inertial "
        'frame, m (default: the origin); for bodies side by side in one view',
    )
    options.add_argument(
        '--commands',
        metavar='BAG_DIR',
        help='re-simulate a scene with a torque_command effect, commanded reaction_wheels or '
        'magnetorquers under the commands this bag recorded on their topics (in --namespace), '
        'each offered at '
        "its log time under the node's rules: with the recording's --rate and --start-time (its "
        'first stamp), the samples equal the recorded ones bit for bit; commands logged before '
        '--start-time are left out. The sensor changes it recorded (sensor_changes: the faults '
        'and sensor_noise parameters set while the node ran) are applied at the samples they '
        'reached, so faulted sensor outputs replay bit for bit too',
    )
    options.add_argument(
        '--reindex',
        metavar='BAG_DIR',
        help='instead of simulating: rebuild the summary and metadata.yaml of a bag whose '
        'recorder died, from its .mcap file',
    )
    return parser


@console_command('torquefree_bag')
def main(argv=None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.reindex:
        try:
            metadata, damage, repaired = reindex(args.reindex)
        except (BagError, OSError) as error:
            print(f'torquefree_bag: {error}', file=sys.stderr)
            return 1
        print(f'{args.reindex}: {metadata.message_count} messages indexed')
        if repaired:
            print(f'{args.reindex}: repaired: {repaired}; no message was lost')
        if damage:
            print(f'torquefree_bag: {args.reindex}: {damage}', file=sys.stderr)
            return 1
        return 0
    missing = [
        flag
        for flag, value in (
            ('SCENE', args.scene),
            ('--duration', args.duration),
            ('--rate', args.rate),
            ('--output', args.output),
        )
        if value is None
    ]
    if missing:
        parser.error(f'missing {", ".join(missing)}')
    if not math.isfinite(args.start_time) or args.start_time < 0 or args.start_time >= 2**31:
        parser.error(f"--start-time: must be in [0, 2^31) s, got '{args.start_time}'")
    if args.position is not None and not all(map(math.isfinite, args.position)):
        parser.error(f'--position: every coordinate must be finite, got {args.position}')
    if not args.namespace.startswith('/'):
        parser.error(f"--namespace: must start with '/', got {args.namespace!r}")
    try:
        scene = load_scene(args.scene)
        started = time.perf_counter()
        progress = Progress(args.rate, len(scene.members()))
        with GracefulStop() as stop:
            try:
                metadata = write_scene_bag(
                    scene,
                    args.output,
                    args.duration,
                    args.rate,
                    epoch_ns=int((args.start_time * 10**9).to_integral_value()),
                    commands_bag=args.commands,
                    propagator=args.propagator,
                    body_frame=args.body_frame,
                    inertial_frame=args.inertial_frame,
                    namespace=args.namespace,
                    overwrite=args.overwrite,
                    compression=args.compression,
                    position=args.position,
                    progress=progress.report,
                    stop=stop,
                )
            finally:
                progress.close()
    except (SceneError, ValueError) as error:
        parser.error(str(error))
    except BagError as error:
        print(f'torquefree_bag: {error}', file=sys.stderr)
        return 1
    except RuntimeError as error:
        # a sample the integrator refuses to reach (step budget, stiffness)
        print(
            f'torquefree_bag: {error}\n'
            f'torquefree_bag: {args.output} is a complete bag of the samples before it',
            file=sys.stderr,
        )
        return 1
    elapsed = time.perf_counter() - started
    samples = metadata.topics[0].message_count if metadata.topics else 0
    if stop.signal is not None:
        print(
            f'torquefree_bag: interrupted: {args.output} is a complete bag of the first {samples} '
            f'samples ({metadata.message_count} messages)',
            file=sys.stderr,
        )
        return INTERRUPTED
    print(
        f'{args.output}: {samples} samples ({metadata.message_count} messages) in '
        f'{elapsed:.2f} s, {samples / max(elapsed, 1e-9):.0f} samples/s'
    )
    return 0


if __name__ == '__main__':
    sys.exit(main())
