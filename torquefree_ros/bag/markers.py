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
ARROWs from the box's centre along ``w`` and ``H``, then a TEXT_VIEW_FACING label just past each
arrow's tip (``w``, ``H``), all in the inertial frame and all in every message, so that the latest
message alone (what a viewer shows after a seek or a late join) is the whole picture. Each marker
has its own namespace and id 0, so every message replaces the last; lifetime 0. Arrows are given by
start and end points (scale: shaft and head diameters; head length 0, so viewers size the head from
the length), which RViz, Foxglove and Lichtblick all draw. numpy only, like :mod:`.cdr`.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from .cdr import CdrTemplate, MessageBlock

CUBE, ARROW, TEXT_VIEW_FACING, ADD = 1, 0, 9, 0  # visualization_msgs/Marker constants


class Style(NamedTuple):
    """One marker of every message: its namespace, marker type, RGBA and sizes."""

    namespace: str
    kind: int
    color: tuple
    # fractions of the box's longest side: an arrow's shaft and head diameters, a label's height
    size: tuple = ()
    text: str = ''


BODY = Style('body', CUBE, (0.62, 0.66, 0.72, 0.55))  # see-through: the arrows inside stay visible
# Colours no frame axis has (the views draw frames and poses as red, green and blue axes): magenta
# w, amber H. Shafts thicker than the shipped views' pose and frame axes, so that an arrow along a
# body axis is not lost inside it; w thicker than H, so that where the two are parallel (a spin
# about a principal axis) the longer H comes out of the w arrow.
ANGULAR_VELOCITY = Style('angular_velocity', ARROW, (0.90, 0.20, 0.90, 1.0), (0.06, 0.14))
ANGULAR_MOMENTUM = Style('angular_momentum', ARROW, (1.00, 0.62, 0.00, 1.0), (0.04, 0.10))
# each arrow's name, in its colour, LABEL_GAP (of the longest side) past its tip
ANGULAR_VELOCITY_LABEL = Style(
    'angular_velocity_label', TEXT_VIEW_FACING, ANGULAR_VELOCITY.color, (0.10,), 'w'
)
ANGULAR_MOMENTUM_LABEL = Style(
    'angular_momentum_label', TEXT_VIEW_FACING, ANGULAR_MOMENTUM.color, (0.10,), 'H'
)
LABEL_GAP = 0.10


def add_marker(template: CdrTemplate, frame_id: str, style: Style) -> None:
    """Append one marker of ``style`` to ``template``: its fixed fields, its filled ones named."""
    namespace, marker_type, color = style.namespace, style.kind, style.color
    template.stamp(namespace)
    template.string(frame_id, 'frame_id')
    template.string(namespace, 'ns')
    template.int32(0)  # id
    template.int32(marker_type)
    template.int32(ADD)
    # pose.position (the box's centre, a label's place; arrows use points)
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
    template.string(style.text)  # text
    template.string('')  # mesh_resource
    template.string('')  # mesh_file.filename
    template.uint32(0)  # mesh_file.data
    template.boolean(False)  # mesh_use_embedded_materials


# every message, in this order
STYLES = (
    BODY,
    ANGULAR_VELOCITY,
    ANGULAR_MOMENTUM,
    ANGULAR_VELOCITY_LABEL,
    ANGULAR_MOMENTUM_LABEL,
)


@functools.lru_cache(maxsize=16)
def _template(frame_id: str) -> CdrTemplate:
    template = CdrTemplate()
    template.uint32(len(STYLES))
    for style in STYLES:
        add_marker(template, frame_id, style)
    return template


def marker_columns(rows: np.ndarray, position) -> dict:
    """Return the filled fields of the five markers from the output's ``rows``, by name."""
    longest = rows[:, 4:7].max(axis=1, keepdims=True)
    columns = {'body.orientation': rows[:, 0:4], 'body.scale': rows[:, 4:7]}
    for arrow, label, tip in (
        (ANGULAR_VELOCITY, ANGULAR_VELOCITY_LABEL, rows[:, 7:10]),
        (ANGULAR_MOMENTUM, ANGULAR_MOMENTUM_LABEL, rows[:, 10:13]),
    ):
        shaft, head = arrow.size
        columns[f'{arrow.namespace}.scale'] = longest * np.array([shaft, head, 0.0])
        columns[f'{arrow.namespace}.tip'] = tip if position is None else tip + position
        if position is not None:
            columns[f'{arrow.namespace}.start'] = position
        (height,) = label.size
        columns[f'{label.namespace}.scale'] = longest * np.array([0.0, 0.0, height])
        place = _past_the_tip(tip, longest * LABEL_GAP)
        columns[f'{label.namespace}.position'] = place if position is None else place + position
    if position is not None:
        columns['body.position'] = position
    return columns


def _past_the_tip(tips: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """
    Return the points ``gaps`` past ``tips`` along each arrow from the origin (a zero arrow: 0).

    Element by element (no reductions), so that a row gives the same bits in a block of any size;
    hypot, so that no length overflows.
    """
    lengths = np.hypot(np.hypot(tips[:, 0], tips[:, 1]), tips[:, 2])[:, None]
    units = np.divide(tips, lengths, out=np.zeros_like(tips), where=lengths > 0.0)
    return tips + units * gaps


def encode_markers(stamps_ns, frame_id: str, rows, position=None) -> MessageBlock:
    """
    Encode one MarkerArray per row: the box, the ``w`` and ``H`` arrows and their labels.

    ``position`` (x, y, z in ``frame_id``, m): where the body's centre is drawn (None: the origin).
    """
    rows = np.asarray(rows, dtype=np.float64)
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    if rows.shape[0] == 0:  # an output at a rate of its own may have no sample in a block
        return MessageBlock(b'', 0)
    return _template(frame_id).fill(stamps_ns, marker_columns(rows, body_offset(position)))


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
