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
``torquefree_play``: a bag replayed onto its topics, like ``ros2 bag play``.

Its messages go out with the recorded timing.
"""

from __future__ import annotations

import argparse
import math
import sys

import rclpy
from rclpy.executors import SingleThreadedExecutor

from .common import console_command
from ..bag import BagError, BagReader
from ..ros.player import BagPlayer
from ..ros.process import init, process_main, shut_down, Spinner


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='torquefree_play',
        description='Replay a rosbag2 MCAP bag onto its topics with the recorded timing and QoS; '
        'message i goes out (t_i - t_0) / rate after the start.',
    )
    parser.add_argument('bag', metavar='BAG', help='bag directory (or its .mcap file)')
    parser.add_argument(
        '--rate', '-r', type=float, default=1.0, help='playback speed multiplier (default: 1)'
    )
    parser.add_argument(
        '--clock',
        type=float,
        nargs='?',
        const=40.0,
        default=0.0,
        metavar='HZ',
        help="publish the bag's time on /clock at HZ (default: off; 40 Hz when given without HZ)",
    )
    parser.add_argument(
        '--loop', '-l', action='store_true', help='start over at the end, until Ctrl-C'
    )
    parser.add_argument(
        '--topics',
        nargs='+',
        metavar='TOPIC',
        help='only these topics, as recorded (default: all)',
    )
    parser.add_argument(
        '--wait-for-subscribers',
        type=float,
        default=0.0,
        metavar='SECONDS',
        help='first wait up to this long until every topic has a subscriber (default: 0)',
    )
    return parser


@console_command('torquefree_play')
def main(argv=None) -> int:
    argv = sys.argv if argv is None else argv
    parser = _parser()
    args = parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    if not (math.isfinite(args.rate) and args.rate > 0):
        parser.error(f'--rate: must be a finite number > 0, got {args.rate!r}')
    if not (math.isfinite(args.clock) and args.clock >= 0):
        parser.error(f'--clock: must be a rate in Hz > 0, got {args.clock!r}')
    if not (math.isfinite(args.wait_for_subscribers) and args.wait_for_subscribers >= 0):
        parser.error(
            '--wait-for-subscribers: must be a number of seconds >= 0, '
            f'got {args.wait_for_subscribers!r}'
        )
    try:
        bag = BagReader(args.bag)
    except BagError as error:
        print(f'torquefree_play: {error}', file=sys.stderr)
        return 1
    if not bag.complete:
        why = bag.damage or bag.repairable
        damage = f' ({why})' if why else ''
        print(
            f"torquefree_play: bag '{args.bag}' is incomplete{damage}: "
            f'{bag.message_count} readable messages; '
            f'`torquefree_bag --reindex {args.bag}` makes it complete',
            file=sys.stderr,
        )
        if bag.message_count == 0:
            return 1
    if args.topics:
        unknown = sorted(set(args.topics) - {t.name for t in bag.topics})
        if unknown:
            parser.error(f'--topics: not in the bag: {", ".join(unknown)}')
    init(argv)
    node = executor = spinner = None
    status = 0 if bag.complete else 1
    try:
        executor = SingleThreadedExecutor()  # first: a signal during start-up then finds it whole
        node = BagPlayer(bag, args.rate, args.clock, args.loop, args.topics)
        executor.add_node(node)
        spinner = Spinner(executor)
        spinner.start()
        if args.wait_for_subscribers > 0 and not node.wait_for_subscribers(
            args.wait_for_subscribers
        ):
            node.get_logger().warning('not every topic has a subscriber; playing anyway')
        node.play()
    except KeyboardInterrupt:
        pass
    except BagError as error:  # damage found while playing: what came before it went out
        print(f'torquefree_play: {error}', file=sys.stderr)
        status = 1
    finally:
        if node is not None:
            node.stop()
            print(f'{args.bag}: played {node.played} messages', file=sys.stderr)
        shut_down(executor, node, spinner)
    return status


# the console script (setup.py) and `python -m`: the process ends right after a clean shutdown
run = process_main(main)

if __name__ == '__main__':
    run()
