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
Scenes: a body, an initial state, the effects it calls for and the outputs it wants.

- :mod:`.loader`: a scene file (YAML) or mapping checked field by field into a :class:`Scene`
  (every error a :class:`SceneError` naming the file and the field path), the built-in default.
- :mod:`.library`: the scenes shipped with the package, by name.

May import: :mod:`..propagators` and every room below it, :mod:`torquefree_ros.files`.
"""

from .loader import default_scene, load_scene, Scene, scene_from_mapping, SceneError

__all__ = ['Scene', 'SceneError', 'default_scene', 'load_scene', 'scene_from_mapping']
