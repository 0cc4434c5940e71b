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
pytest plugin (the ``pytest11`` entry point ``torquefree_ros``): the ``torquefree_sim`` fixture.

    @pytest.mark.torquefree_sim(scene="dzhanibekov", publish_rate=50.0)
    def test_something(torquefree_sim):
        torquefree_sim.advance(10)

or, one test per set of parameters, through indirect parametrization (a dict of parameters, or a
scene's name)::

    @pytest.mark.parametrize(
        "torquefree_sim", ["dzhanibekov", {"scene": "explorer1"}], indirect=True
    )

Both may be given: the parametrization's values win. Each test gets a fresh simulator in a ROS
domain of its own (its node in the root namespace, unless ``namespace=...`` names one), closed
after the test (every node added to it destroyed), so tests can run in parallel under pytest-xdist.
rclpy is imported only when a test asks for the fixture.
"""

from __future__ import annotations

import pytest

MARKER = 'torquefree_sim'


def pytest_configure(config):
    config.addinivalue_line(
        'markers',
        f"{MARKER}(scene=None, **parameters): the torquefree_sim fixture's scene, node parameters "
        '(publish_rate=..., angular_velocity=...) and kit options (timeout=..., stepped=...)',
    )


def _parameters(request) -> dict:
    parameters: dict = {}
    marker = request.node.get_closest_marker(MARKER)
    if marker is not None:
        if len(marker.args) > 1:
            raise pytest.UsageError(
                f'@pytest.mark.{MARKER}: at most one positional argument (the scene), '
                f'got {marker.args!r}'
            )
        if marker.args:
            parameters['scene'] = marker.args[0]
        parameters.update(marker.kwargs)
    param = getattr(request, 'param', None)
    if isinstance(param, str):
        parameters['scene'] = param
    elif isinstance(param, dict):
        parameters.update(param)
    elif param is not None:
        raise pytest.UsageError(
            f"torquefree_sim: an indirect parameter is a scene's name or a dict of parameters, "
            f'got {param!r}'
        )
    return parameters


@pytest.fixture
def torquefree_sim(request):
    """
    Yield a started :class:`torquefree_ros.testing.Simulator`.

    The test steps it (``advance``).
    """
    from .kit import simulator

    with simulator(**_parameters(request)) as sim:
        yield sim
