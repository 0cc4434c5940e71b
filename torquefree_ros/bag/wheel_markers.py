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
The ``markers`` output of a scene with reaction wheels: the five markers, then an arrow per wheel.

The first five markers are :mod:`.markers`' own, byte for byte the same fields; after them, per
wheel (in the scene's order), an ARROW in its own namespace ``wheel_NAME`` (id 0), from the body's
centre along the wheel's spin axis, its length the momentum the wheel stores relative to the body
(``Js Omega``, signed: it points along ``-axis`` when the wheel spins backwards) at the H arrow's
scale, teal (a colour no frame axis, nor w or H, has). The row is the markers row followed by each
wheel arrow's tip (x, y, z, inertial frame, from the box's centre).
"""

from __future__ import annotations

import functools

import numpy as np

from .cdr import CdrTemplate, MessageBlock
from .markers import add_marker, ARROW, body_offset, marker_columns, Style, STYLES
from ..core.effects.outputs import MARKER_ROW

WHEEL_COLOR = (0.00, 0.72, 0.72, 1.0)  # teal
WHEEL_ARROW = (0.03, 0.07)  # shaft and head diameters, of the box's longest side: under H's


def wheel_style(name: str) -> Style:
    """Return the marker style of the wheel ``name``: its namespace ``wheel_NAME``."""
    return Style(f'wheel_{name}', ARROW, WHEEL_COLOR, WHEEL_ARROW)


@functools.lru_cache(maxsize=16)
def _template(frame_id: str, names: tuple) -> CdrTemplate:
    template = CdrTemplate()
    template.uint32(len(STYLES) + len(names))
    for style in STYLES + tuple(wheel_style(name) for name in names):
        add_marker(template, frame_id, style)
    return template


def encode_wheel_markers(stamps_ns, frame_id: str, rows, position=None, names=()) -> MessageBlock:
    """
    Encode one MarkerArray per row: the five markers, then an arrow per wheel of ``names``.

    ``position`` as :func:`.markers.encode_markers` takes it.
    """
    rows = np.asarray(rows, dtype=np.float64)
    stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
    if rows.shape[0] == 0:
        return MessageBlock(b'', 0)
    offset = body_offset(position)
    columns = marker_columns(rows, offset)
    longest = rows[:, 4:7].max(axis=1, keepdims=True)
    shaft, head = WHEEL_ARROW
    for index, name in enumerate(names):
        namespace = wheel_style(name).namespace
        tip = rows[:, MARKER_ROW + 3 * index: MARKER_ROW + 3 * index + 3]
        columns[f'{namespace}.scale'] = longest * np.array([shaft, head, 0.0])
        columns[f'{namespace}.tip'] = tip if offset is None else tip + offset
        if offset is not None:
            columns[f'{namespace}.start'] = offset
    return _template(frame_id, tuple(names)).fill(stamps_ns, columns)
