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

"""``torquefree_sim``: the attitude simulator node (``ros2 run torquefree_ros torquefree_sim``)."""

from __future__ import annotations

import argparse
import sys
import textwrap

import rclpy
from rclpy.executors import SingleThreadedExecutor

from .common import console_command
from ..ros.node import TorqueFreeSim
from ..ros.parameters import ConfigurationError, SPECS
from ..ros.process import init, process_main, shut_down, Spinner

SWITCH_INTERVAL = 0.0005  # s: the interpreter's, for this process (see main)


def _parameter_help() -> str:
    lines = ['parameters (--ros-args -p NAME:=VALUE, or --params-file FILE):']
    for spec in SPECS:
        default = 'not set' if spec.default is None else repr(spec.default)
        flags = ', read-only' if spec.read_only else ''
        lines.append(f'  {spec.name} (default {default}{flags})')
        lines += textwrap.wrap(
            spec.description, 96, initial_indent='      ', subsequent_indent='      '
        )
        lines += textwrap.wrap(
            f'valid: {spec.constraints}', 96, initial_indent='      ', subsequent_indent='      '
        )
    return '\n'.join(lines)


def _parser() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(
        prog='torquefree_sim',
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="The torque-free attitude simulator node (default name 'torquefree'). It "
        'publishes angular_velocity (Vector3Stamped, body frame) and attitude (QuaternionStamped, '
        'q_NB), serves ~/reset (std_srvs/Trigger) and ~/pause (std_srvs/SetBool) and reports on '
        '/diagnostics. Ctrl-C or SIGTERM stop it with exit status 0.',
        epilog=_parameter_help()
        + '\n\nexample: torquefree_sim --ros-args -p scene:=dzhanibekov -p publish_rate:=200.0',
    )


@console_command('torquefree_sim')
def main(argv=None) -> int:
    """
    Run the simulator node until a signal stops it; return the exit status.

    Exit status 0 on SIGINT/SIGTERM, 1 when the parameters do not describe a usable simulation,
    2 on a bad command line.
    """
    argv = sys.argv if argv is None else argv
    # --help exits here, before any DDS
    _parser().parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    init(argv)
    # this process is the node's own: a free-running loop (real_time_factor 0) holds the GIL
    # between samples, and the executor's thread waits up to the switch interval each time it
    # takes the GIL back after a blocking call (at 5 ms a reset's log line alone took ~100 ms)
    sys.setswitchinterval(SWITCH_INTERVAL)
    node = executor = spinner = None
    try:
        executor = SingleThreadedExecutor()  # first: a signal during start-up then finds it whole
        node = TorqueFreeSim()
        executor.add_node(node)
        spinner = Spinner(executor)
        spinner.start()
        spinner.wait()
        if spinner.error is not None:
            raise spinner.error
    except ConfigurationError as error:
        rclpy.logging.get_logger('torquefree').fatal(f'cannot start: {error}')
        return 1
    except KeyboardInterrupt:
        pass
    finally:
        shut_down(executor, node, spinner)
    return 0


# the console script (setup.py) and `python -m`: the process ends right after a clean shutdown
run = process_main(main)

if __name__ == '__main__':
    run()
