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

"""The README's Python quick tour runs as written, and says what it prints."""

from __future__ import annotations

from pathlib import Path
import re

README = Path(__file__).resolve().parents[1] / 'README.md'


def test_the_quick_tour_runs_as_written():
    text = README.read_text(encoding='utf-8')
    tour = text[text.index('## Quick tour'):]
    code = re.search(r'```python\n(.*?)```', tour, re.S).group(1)
    namespace: dict = {}
    exec(compile(code, 'README quick tour', 'exec'), namespace)  # noqa: S102 - our own README
    assert namespace['w'].shape[0] == namespace['times'].size
    assert namespace['W'].shape == (1000, 601, 3) and namespace['Q'].shape == (1000, 601, 4)
    summary = (
        namespace['RigidBody'].from_inertia([1.0, 2.0, 3.0]).classify([1e-4, 1.0, 1e-4]).summary()
    )
    assert f"# '{summary}'" in code  # the output the tour shows is the output it gives


def test_the_example_test_shown_is_the_example_test():
    text = README.read_text(encoding='utf-8')
    section = text[text.index('### Testing your node against torquefree_ros'):]
    shown = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    example = README.parent / 'examples' / 'test_attitude_estimator.py'
    source = example.read_text(encoding='utf-8')
    license_header, _, code = source.partition('\n\n')
    assert license_header.startswith('# Copyright') and shown == code
