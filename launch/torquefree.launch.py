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

r"""
Start the torque-free attitude simulator, optionally recording a bag and opening RViz.

RViz, when asked for (``rviz:=true``), opens on the shipped view.

    ros2 launch torquefree_ros torquefree.launch.py scene:=dzhanibekov rviz:=true
    ros2 launch torquefree_ros torquefree.launch.py namespace:=sat1 \
        params_file:=my_params.yaml record_bag:=/tmp/run1

Arguments (``ros2 launch torquefree_ros torquefree.launch.py --show-args``):

* ``scene``: a library scene name or a scene file; empty = the parameter file's (the built-in
  default scene with the shipped file). The shipped views show ``/tf`` and ``/markers``:
  ``dzhanibekov`` and ``explorer1`` name both.
* ``params_file``: the node's parameter file (default: the shipped ``config/torquefree.yaml``,
  every parameter at its default); ``scene`` and ``record_bag`` given here override it.
* ``namespace``: the node's namespace (its relative topics move into it; ``/tf`` stays shared).
* ``use_sim_time``: ``true`` makes the node's neighbours started here (RViz) follow the simulator's
  ``/clock``, and sets the simulator's ``publish_clock`` so that there is one whatever
  ``real_time_factor`` the parameter file sets (at 1 it would publish none, and a neighbour on sim
  time would wait for it forever). The simulator itself never takes ``use_sim_time``: it is the
  clock. ``false`` (default) leaves ``publish_clock`` to the file.
* ``record_bag``: a bag directory to record every sample into; empty = no recording.
* ``rviz``: ``true`` opens RViz on ``share/torquefree_ros/rviz/torquefree.rviz``.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

PACKAGE = 'torquefree_ros'
EXECUTABLE = 'torquefree_sim'  # a console script of setup.py
PARAMS_FILE = os.path.join('config', 'torquefree.yaml')  # under share/torquefree_ros
RVIZ_CONFIG = os.path.join('rviz', 'torquefree.rviz')
#: topics the shipped RViz view names absolutely; remapped into the namespace when one is given
VIEW_TOPICS = ('/markers', '/pose')

ARGUMENTS = (
    ('scene', '', "library scene name or scene file; empty = the parameter file's"),
    ('params_file', '', "the node's parameter file; empty = the shipped config/torquefree.yaml"),
    ('namespace', '', "the node's namespace; empty = none"),
    (
        'use_sim_time',
        'false',
        "true: the neighbours started here (RViz) follow the simulator's /clock, which "
        'the simulator then publishes at any real_time_factor (publish_clock)',
    ),
    ('record_bag', '', 'bag directory to record the samples into; empty = no recording'),
    ('rviz', 'false', 'true: open RViz on the shipped configuration'),
)


def _is_true(text: str, name: str) -> bool:
    value = text.strip().lower()
    if value not in ('true', 'false'):
        raise ValueError(f"{name}: expected true or false, got '{text}'")
    return value == 'true'


def _actions(context):
    def value(name: str) -> str:
        return LaunchConfiguration(name).perform(context)

    share = get_package_share_directory(PACKAGE)
    namespace = value('namespace').strip('/')
    use_sim_time = _is_true(value('use_sim_time'), 'use_sim_time')
    # only what is given here overrides the file: an empty scene would replace its scene by
    # the default one
    overrides = {'scene': value('scene'), 'record_bag': value('record_bag')}
    parameters = [value('params_file') or os.path.join(share, PARAMS_FILE)]
    parameters += [{name: given} for name, given in overrides.items() if given]
    if use_sim_time:  # a neighbour on sim time needs a /clock, also at real_time_factor 1
        parameters.append({'publish_clock': True})
    actions = [
        Node(
            package=PACKAGE,
            executable=EXECUTABLE,
            name='torquefree',
            namespace=namespace,
            parameters=parameters,
            output='screen',
            emulate_tty=True,
        )
    ]
    if _is_true(value('rviz'), 'rviz'):
        remappings = (
            [(topic, f'/{namespace}{topic}') for topic in VIEW_TOPICS] if namespace else []
        )
        actions.append(
            Node(
                package='rviz2',
                executable='rviz2',
                name='rviz2',
                namespace=namespace,
                arguments=['-d', os.path.join(share, RVIZ_CONFIG)],
                remappings=remappings,
                parameters=[{'use_sim_time': use_sim_time}],
                output='screen',
            )
        )
    return actions


def generate_launch_description():
    declared = [
        DeclareLaunchArgument(name, default_value=default, description=description)
        for name, default, description in ARGUMENTS
    ]
    return LaunchDescription(declared + [OpaqueFunction(function=_actions)])
