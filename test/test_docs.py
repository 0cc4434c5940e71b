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
The API reference (``docs/api``) builds with Sphinx, warnings as errors, as ``make docs`` does.

Every name a public module exports (its ``__all__``) is documented under its public import path.
"""

import importlib
from pathlib import Path
import subprocess
import sys

REPO = Path(__file__).resolve().parents[1]
# page of the reference: the public module it documents
PAGES = {
    'torquefree_ros': 'torquefree_ros',
    'testing': 'torquefree_ros.testing',
    'campaigns': 'torquefree_ros.campaigns',
    'gym': 'torquefree_ros.plant.gym',
}


def test_the_api_reference_builds_without_warnings_and_documents_every_public_name(tmp_path):
    html = tmp_path / 'html'
    build = subprocess.run(
        [
            sys.executable, '-m', 'sphinx', '-W', '--keep-going', '-q', '-b', 'html',
            '-d', str(tmp_path / 'doctrees'), str(REPO / 'docs' / 'api'), str(html),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, f'sphinx-build failed:\n{build.stdout}{build.stderr}'
    for extra in ('index', 'contract', 'scenes'):
        assert (html / f'{extra}.html').is_file(), extra
    missing = []
    for page, module_name in PAGES.items():
        text = (html / f'{page}.html').read_text(encoding='utf-8')
        for name in importlib.import_module(module_name).__all__:
            if f'id="{module_name}.{name}"' not in text:
                missing.append(f'{module_name}.{name} (docs/api/{page}.rst)')
    assert missing == [], f'public names without an entry in the reference: {missing}'
