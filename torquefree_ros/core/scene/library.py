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
The scene library: the YAML files in ``torquefree_ros/scenes/``.

They are shipped inside the package (so a source checkout, a wheel and a colcon install all find
them the same way) and also installed under ``share/torquefree_ros/config/scenes`` for ROS users to
browse.
"""

from __future__ import annotations

from pathlib import Path

LIBRARY_DIRECTORY = Path(__file__).resolve().parent.parent.parent / 'scenes'


def library_scenes() -> dict[str, Path]:
    """Name -> file of every library scene."""
    return {path.stem: path for path in sorted(LIBRARY_DIRECTORY.glob('*.yaml'))}


def is_scene_name(text: str) -> bool:
    """
    Tell a bare scene name (``explorer1``) from a path.

    True for a bare name, false for a path (``./explorer1``, ``a/b.yaml``, ``x.yaml``).
    """
    return (
        bool(text)
        and '/' not in text
        and '\\' not in text
        and not text.endswith(('.yaml', '.yml'))
    )
