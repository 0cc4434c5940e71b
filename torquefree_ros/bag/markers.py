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
The ``markers`` output's ``visualization_msgs/MarkerArray``, encoded a block at a time.

Each message is encoded from its row (``core.effects.outputs.MARKER_ROW``): the box (a CUBE), then
ARROWs from the box's centre along ``w`` and ``H``, all in the inertial frame and all in every
message, so that the latest message alone (what a viewer shows after a seek or a late join) is the
whole picture. Each marker has its own namespace and id 0, so every message replaces the last;
lifetime 0. Arrows are given by start and end points (scale: shaft and head diameters; head length
0, so viewers size the head from the length), which RViz, Foxglove and Lichtblick all draw. numpy
only, like :mod:`.cdr`.
"""

from __future__ import annotations

import functools

import numpy as np

from .cdr import CdrTemplate, MessageBlock

CUBE, ARROW, ADD = 1, 0, 0  # visualization_msgs/Marker constants
# (namespace, marker type, RGBA, shaft and head diameter as fractions of the box's longest side)
BODY = ('body', CUBE, (0.62, 0.66, 0.72, 0.55), None)
ANGULAR_VELOCITY = ('angular_velocity', ARROW, (0.90, 0.25, 0.20, 1.0), (0.03, 0.07))
ANGULAR_MOMENTUM = ('angular_momentum', ARROW, (0.20, 0.45, 0.95, 1.0), (0.02, 0.05))


def _marker(template: CdrTemplate, frame_id: str, style) -> None:
    namespace, marker_type, color, _ = style
    template.stamp(namespace)
    template.string(frame_id, 'frame_id')
    template.string(namespace, 'ns')
    template.int32(0)  # id
    template.int32(marker_type)
    template.int32(ADD)
    # pose.position (the box; arrows use points)
    template.float64([0.0, 0.0, 0.0], f'{namespace}.position')
    template.float64([0.0, 0.0, 0.0, 1.0], f'{namespace}.orientation')
    template.float64([0.0, 0.0, 0.0], f'{namespace}.scale')
    template.float32(color)
    template.int32(0), template.uint32(0)  # lifetime: forever (until replaced)
    template.boolean(False)  # frame_locked
    if marker_type == ARROW:
        template.uint32(2)  # points: start, end
        template.float64([0.0, 0.0, 0.0], f'{namespace}.start')
        template.float64([0.0, 0.0, 0.0], f'{namespace}.tip')
    else:
        template.uint32(0)
    template.uint32(0)  # colors
    template.string('')  # texture_resource
    template.int32(0), template.uint32(0), template.string('')  # texture.header
    template.string('')  # texture.format
    template.uint32(0)  # texture.data
    template.uint32(0)  # uv_coordinates
    template.string('')  # text
    template.string('')  # mesh_resource
    template.string('')  # mesh_file.filename
    template.uint32(0)  # mesh_file.data
    template.boolean(False)  # mesh_use_embedded_materials


STYLES = (BODY, ANGULAR_VELOCITY, ANGULAR_MOMENTUM)  # every message, in this order


@functools.lru_cache(maxsize=16)
def _template(frame_id: str) -> CdrTemplate:
    template = CdrTemplate()
    template.uint32(len(STYLES))
    for style in STYLES:
        _marker(template, frame_id, style)
    return template


def _columns(rows: np.ndarray, position) -> dict:
    longest = rows[:, 4:7].max(axis=1, keepdims=True)
    columns = {'body.orientation': rows[:, 0:4], 'body.scale': rows[:, 4:7]}
    for (namespace, _, _, (shaft, head)), tip in (
        (ANGULAR_VELOCITY, rows[:, 7:10]),
        (ANGULAR_MOMENTUM, rows[:, 10:13]),
    ):
        columns[f'{namespace}.scale'] = longest * np.array([shaft, head, 0.0])
        columns[f'{namespace}.tip'] = tip if position is None else tip + position
        if position is not None:
            columns[f'{namespace}.start'] = position
    if position is not None:
        columns['body.position'] = position
    return columns


def encode_markers(stamps_ns, frame_id: str, rows, position=None) -> MessageBlock:
    """
    Encode one MarkerArray per row, each with the box, the ``w`` arrow and the ``H`` arrow.

    ``position`` (x, y, z in ``frame_id``, m): where the body's centre is drawn (None: the origin).
    """
    rows = np.asarray(rows, dtype=np.float64)
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    if rows.shape[0] == 0:  # an output at a rate of its own may have no sample in a block
        return MessageBlock(b'', 0)
    return _template(frame_id).fill(stamps_ns, _columns(rows, body_offset(position)))


def body_offset(position) -> np.ndarray | None:
    """
    Return ``position`` as an array, or None at the origin.

    None at the origin so that the origin's bytes stay those of no offset: ``-0.0 + 0.0`` would
    turn a tip's negative zero positive.
    """
    if position is None:
        return None
    position = np.asarray(position, dtype=np.float64)
    return position if np.any(position) else None
