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

"""An orbit's /tf frames that clash with the run's frame names are refused before a run starts."""

from __future__ import annotations

import pytest
from test_tf_orbit import LEO, tf_scene_mapping
from torquefree_ros.bag.offline import write_scene_bag
from torquefree_ros.bag.samples import check_output_frames
from torquefree_ros.core.scene.loader import scene_from_mapping


def _scene(tf, orbit=LEO):
    return scene_from_mapping(tf_scene_mapping(tf, orbit), source='s.yaml')


@pytest.mark.parametrize(
    'tf, body_frame, inertial_frame, clash',
    [
        ({}, 'body', 'earth_fixed', "'earth_fixed' (earth_frame)"),
        ({}, 'body', 'lvlh', "'lvlh' (lvlh_frame)"),
        ({'lvlh_frame': 'body'}, 'body', 'world', "'body' (lvlh_frame)"),
        ({'earth_frame': 'lvlh'}, 'body', 'world', "'lvlh' (earth_frame)"),
        # the orbit's frames take the body frame's namespace
        ({'earth_frame': 'body'}, 'sat1/body', 'world', "'sat1/body' (earth_frame)"),
        ({}, 'sat1/body', 'sat1/lvlh', "'sat1/lvlh' (lvlh_frame)"),
    ],
)
def test_clashing_frames_are_refused_naming_the_output_and_each_frame(
    tf, body_frame, inertial_frame, clash
):
    outputs = _scene(tf).outputs
    with pytest.raises(ValueError, match='must all differ') as raised:
        check_output_frames(outputs, body_frame, inertial_frame)
    message = str(raised.value)
    assert message.startswith('tf output: the frames ')
    assert clash in message
    assert f'{inertial_frame!r} (inertial)' in message


@pytest.mark.parametrize(
    'tf, body_frame, inertial_frame',
    [
        ({}, 'body', 'world'),
        ({}, 'sat1/body', 'lvlh'),  # the orbit's frame is sat1/lvlh: no clash
        ({'earth_frame': 'ecef', 'lvlh_frame': 'orbit'}, 'body', 'earth_fixed'),
    ],
)
def test_distinct_frames_pass(tf, body_frame, inertial_frame):
    check_output_frames(_scene(tf).outputs, body_frame, inertial_frame)


def test_without_an_orbit_tf_has_no_frames_of_its_own_to_clash():
    check_output_frames(_scene({}, orbit=None).outputs, 'body', 'earth_fixed')


def test_an_offline_bag_with_clashing_frames_is_refused_before_anything_is_written(tmp_path):
    out = tmp_path / 'bag'
    with pytest.raises(ValueError, match="tf output: .*'earth_fixed' \\(earth_frame\\)"):
        write_scene_bag(_scene({}), out, 1.0, 10.0, inertial_frame='earth_fixed')
    assert not out.exists()
