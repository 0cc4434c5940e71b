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

"""``torquefree_record``: records topics into a rosbag2 MCAP bag, like ``ros2 bag record``."""

from __future__ import annotations

import argparse
import math
import sys
import time

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.exceptions import InvalidTopicNameException
from rclpy.executors import SingleThreadedExecutor
from rclpy.validate_topic_name import validate_topic_name

from .common import console_command
from ..bag import BagError, BagWriter
from ..bag.writer import COMPRESSIONS
from ..ros.process import init, process_main, shut_down, Spinner
from ..ros.recorder import TopicRecorder

MAX_DURATION = 1e9  # s (~32 years): larger values are a typo, not a plan


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='torquefree_record',
        description='Record topics into a rosbag2 (Jazzy) MCAP bag until Ctrl-C / SIGTERM (or '
        "--duration). Each topic keeps its publishers' QoS; reliable delivery is asked for only "
        'when every publisher offers it.',
    )
    parser.add_argument(
        '--output',
        '-o',
        required=True,
        metavar='BAG_DIR',
        help='bag directory to create (required; missing parent directories are created)',
    )
    parser.add_argument(
        '--topics',
        nargs='+',
        metavar='TOPIC',
        help="topic names, resolved like ROS names (relative ones in the node's namespace, "
        'remappings applied); default: every topic that is not hidden',
    )
    parser.add_argument(
        '--include-hidden-topics', action='store_true', help='with all topics, also hidden ones'
    )
    parser.add_argument(
        '--overwrite', action='store_true', help='replace an existing bag directory'
    )
    parser.add_argument(
        '--compression',
        choices=sorted(COMPRESSIONS),
        default='none',
        help='MCAP chunk compression (default: none, like rosbag2)',
    )
    parser.add_argument(
        '--duration',
        type=float,
        metavar='SECONDS',
        help='stop after recording this many seconds, counted from the first message '
        '(default: until a signal)',
    )
    return parser


@console_command('torquefree_record')
def main(argv=None) -> int:
    argv = sys.argv if argv is None else argv
    parser = _parser()
    args = parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    for topic in args.topics or ():
        try:
            validate_topic_name(topic)
        except InvalidTopicNameException as error:
            parser.error(f'--topics: {str(error).splitlines()[0]} ({topic!r})')
    if args.duration is not None and not (
        math.isfinite(args.duration) and 0 < args.duration <= MAX_DURATION
    ):
        parser.error(
            f'--duration: must be a number of seconds in (0, {MAX_DURATION:g}], '
            f'got {args.duration!r}'
        )
    try:
        writer = BagWriter(args.output, overwrite=args.overwrite, compression=args.compression)
    except BagError as error:
        print(f'torquefree_record: {error}', file=sys.stderr)
        return 1
    init(argv)
    node = executor = spinner = None
    try:
        executor = SingleThreadedExecutor()  # first: a signal during start-up then finds it whole
        try:
            node = TopicRecorder(writer, args.topics, args.include_hidden_topics)
        except (InvalidTopicNameException, RCLError) as error:
            print(f'torquefree_record: --topics: {error}', file=sys.stderr)
            return 2
        executor.add_node(node)
        spinner = Spinner(executor)
        spinner.start()
        if args.duration is None:
            spinner.wait()
        else:
            while spinner.is_alive() and not _recorded_for(node, args.duration):
                spinner.wait(0.05)
    except KeyboardInterrupt:
        pass
    finally:
        shut_down(executor, node, spinner)
        try:
            writer.close()
        except BagError as error:
            print(f'torquefree_record: {error}', file=sys.stderr)
            return 1
    print(f'{args.output}: {writer.message_count} messages', file=sys.stderr)
    return 1 if node is not None and node.failure else 0


def _recorded_for(node: TopicRecorder, duration: float) -> bool:
    return (
        node.first_message_time is not None
        and time.monotonic() - node.first_message_time >= duration
    )


# the console script (setup.py) and `python -m`: the process ends right after a clean shutdown
run = process_main(main)

if __name__ == '__main__':
    run()
