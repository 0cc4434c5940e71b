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

from glob import glob

from setuptools import find_packages, setup

package_name = 'torquefree_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'tools']),
    # the scene library ships inside the package, so load_scene("explorer1") works in every install
    package_data={
        'torquefree_ros': ['scenes/*.yaml', 'interfaces/*/msg/*'],
        'torquefree_ros.bench': ['hard_cases.json', 'gyrostat_cases.json'],
        'torquefree_ros.campaigns': ['library/*.yaml'],
    },
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
        ('share/' + package_name + '/config/scenes', glob('torquefree_ros/scenes/*.yaml')),
        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),
        ('share/' + package_name + '/rviz', glob('rviz/*.rviz')),
        ('share/' + package_name + '/foxglove', glob('foxglove/*.json') + glob('foxglove/*.ts')),
    ],
    # What the package imports at run time, all from PyPI (exact versions: requirements.lock). In a
    # ROS install the same come from rosdep (package.xml); colcon does not install these.
    # numba compiles the exact attitude (core/attitude_kernels.py) and the integrators of scenes
    # with effects (core/integrators/); TORQUEFREE_ROS_KERNELS=numpy runs the numpy/scipy reference
    # instead. pyarrow and dask[distributed]: campaigns (the Parquet table, the engine on a local
    # or remote cluster)
    install_requires=[
        'numpy>=1.26',
        'scipy>=1.11',
        'PyYAML>=6',
        'mcap>=1.2',
        'numba>=0.60',
        'pyarrow>=26',
        'dask[distributed]>=2026.8',
        # a two-line element set's orbit (core/environment/tle.py)
        'sgp4>=2.27',
        'ros-jazzy-rclpy[fastrtps]',
        'ros-jazzy-common-interfaces',
    ],
    # mujoco 4.0.0 on PyPI is a shell around the not-yet-usable mujoco-core; 3.x is the real one.
    # fast: numba, now a runtime dependency; the extra stays so that '.[fast]' keeps working
    extras_require={
        'plot': ['matplotlib>=3.7'],
        'bench': ['matplotlib>=3.7', 'mujoco>=3.1,<4', 'cyrk>=0.20'],
        # gym: torquefree_ros.plant.gym (Gymnasium 1.x: AutoresetMode, vector_entry_point)
        'gym': ['gymnasium>=1.0,<2'],
        'fast': ['numba>=0.60'],
    },
    zip_safe=False,  # the scene library and bench data are read as files
    maintainer='torquefree_ros maintainers',
    maintainer_email='maintainers@torquefree-ros.invalid',
    description='Exact torque-free rigid-body attitude simulator for ROS 2',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'torquefree_sim = torquefree_ros.cli.sim:run',
            'torquefree_propagate = torquefree_ros.cli.propagate:main',
            'torquefree_bag = torquefree_ros.cli.bag:main',
            'torquefree_record = torquefree_ros.cli.record:run',
            'torquefree_play = torquefree_ros.cli.play:run',
            'torquefree_plot = torquefree_ros.cli.plot:main',
            'torquefree_bench = torquefree_ros.cli.bench:main',
            'torquefree_campaign = torquefree_ros.cli.campaign:main',
        ],
        # the test kit's torquefree_sim fixture, in every pytest run of an environment with this
        # package
        'pytest11': ['torquefree_ros = torquefree_ros.testing.pytest_plugin'],
    },
)
