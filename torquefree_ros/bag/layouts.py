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
The message layouts of the outputs: one encoder per ``OutputEffect.layout``, by name.

An encoder takes ``(stamps_ns, frame_id, body_frame, rows, place)`` — the samples' stamps, the
output's frame id, the body frame's id, the output's rows (its numbers, as its layout reads them)
and where the body is drawn (None: the origin) — and the output's ``layout_options`` as keywords
(``joint_states``: the joints' ``names``), and returns the messages' CDR bytes. A new
message shape is its encoder here under :func:`layout` (built from :mod:`.cdr`'s pieces) and the
output that names it.
"""

from __future__ import annotations

from typing import Callable

from .cdr import (
    encode_joint_states,
    encode_odometry,
    encode_stamped_doubles,
    encode_transform_lists,
    encode_transforms,
    MessageBlock,
)
from .markers import encode_markers
from .wheel_markers import encode_wheel_markers

#: encoders by layout name
LAYOUTS: dict[str, Callable[..., MessageBlock]] = {}


def layout(*names: str):
    """Register the decorated encoder under each of ``names``."""

    def register(encoder):
        for name in names:
            LAYOUTS[name] = encoder
        return encoder

    return register


@layout('doubles', 'pose')
def _doubles(stamps_ns, frame_id, body_frame, rows, place) -> MessageBlock:
    """Encode a Header, then the row's float64s (header.frame_id: the output's frame)."""
    return encode_stamped_doubles(stamps_ns, frame_id, rows)


@layout('transform')
def _transform(stamps_ns, frame_id, body_frame, rows, place) -> MessageBlock:
    """Encode a TransformStamped: parent the output's frame, child the body frame."""
    return encode_transforms(stamps_ns, frame_id, body_frame, rows)


@layout('orbit_transforms')
def _orbit_transforms(
    stamps_ns, frame_id, body_frame, rows, place, earth_frame='earth_fixed', lvlh_frame='lvlh'
) -> MessageBlock:
    """
    Encode a TFMessage of three transforms from the output's frame: body, Earth-fixed, LVLH.

    The Earth-fixed and LVLH frames are named in the body frame's namespace (its part up to its
    last '/'); ``place`` moves all three by the body's position, so that they stay where the body
    sees them.
    """
    children = orbit_frames(frame_id, body_frame, earth_frame, lvlh_frame)
    if place is not None:
        rows = rows.copy()
        for start in (0, 7, 14):
            rows[:, start: start + 3] += place
    return encode_transform_lists(stamps_ns, [(frame_id, child) for child in children], rows)


def orbit_frames(frame_id, body_frame, earth_frame='earth_fixed', lvlh_frame='lvlh') -> tuple:
    """
    Return the child frames of an orbit's TFMessage: body, Earth-fixed, LVLH.

    The Earth-fixed and LVLH frames take the body frame's namespace (its part up to its last '/').
    ``ValueError`` when two of the four frames (the parent ``frame_id`` among them) share a name.
    """
    namespace = body_frame[: body_frame.rfind('/') + 1]
    children = (body_frame, namespace + earth_frame, namespace + lvlh_frame)
    if len({frame_id, *children}) != 4:
        raise ValueError(
            f'the frames {frame_id!r} (inertial), {children[0]!r} (body), '
            f'{children[1]!r} (earth_frame), {children[2]!r} (lvlh_frame) must all differ'
        )
    return children


@layout('odometry')
def _odometry(stamps_ns, frame_id, body_frame, rows, place) -> MessageBlock:
    """Encode a nav_msgs/Odometry: frame_id the output's frame, child_frame_id the body's."""
    return encode_odometry(stamps_ns, frame_id, body_frame, rows)


@layout('markers')
def _markers(stamps_ns, frame_id, body_frame, rows, place) -> MessageBlock:
    """Encode a MarkerArray drawn from the row, the body's centre at ``place``."""
    return encode_markers(stamps_ns, frame_id, rows, place)


@layout('wheel_markers')
def _wheel_markers(stamps_ns, frame_id, body_frame, rows, place, names=()) -> MessageBlock:
    """Encode the markers' MarkerArray with an arrow per reaction wheel of ``names``."""
    return encode_wheel_markers(stamps_ns, frame_id, rows, place, names)


@layout('joint_states')
def _joint_states(stamps_ns, frame_id, body_frame, rows, place, names=()) -> MessageBlock:
    """Encode a sensor_msgs/JointState of the joints ``names``: positions, velocities, efforts."""
    return encode_joint_states(stamps_ns, frame_id, names, rows)
