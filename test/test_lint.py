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
ROS 2's own linters, as `ros2 pkg create` sets them up, over every Python file of the repository.

ament_flake8 and ament_pep257 run with their own configuration (no options passed: ROS's line
length, quote style, import order and docstring rules); the copyright check stands in for
ament_copyright, which is not on PyPI: every source file starts with the Apache-2.0 header that
ament_copyright accepts, under one copyright line.
"""

from pathlib import Path

from ament_flake8.main import main_with_errors as flake8_main_with_errors
from ament_pep257.main import main as pep257_main
import pytest

REPO = Path(__file__).resolve().parents[1]
# what is ours to lint: the package, its tests, tools, examples, launch file, the API reference's
# Sphinx configuration (docs/api/conf.py) and setup script
LINTED_DIRECTORIES = ['torquefree_ros', 'test', 'tools', 'examples', 'launch', 'docs']
LINTED = [*LINTED_DIRECTORIES, 'setup.py']
COPYRIGHT = 'Copyright 2026 torquefree_ros maintainers'
APACHE_HEADER = (
    'Licensed under the Apache License, Version 2.0 (the "License");',
    'you may not use this file except in compliance with the License.',
    'You may obtain a copy of the License at',
    '',
    '    http://www.apache.org/licenses/LICENSE-2.0',
    '',
    'Unless required by applicable law or agreed to in writing, software',
    'distributed under the License is distributed on an "AS IS" BASIS,',
    'WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.',
    'See the License for the specific language governing permissions and',
    'limitations under the License.',
)


def _paths() -> list[str]:
    return [str(REPO / name) for name in LINTED]


def _sources() -> list[Path]:
    files = [REPO / 'setup.py', *sorted((REPO / 'foxglove').glob('*.ts'))]
    for name in LINTED_DIRECTORIES:
        files += sorted(
            path
            for path in (REPO / name).rglob('*.py')
            if '__pycache__' not in path.parts and 'build' not in path.relative_to(REPO).parts
        )
    return files


@pytest.mark.linter
def test_flake8_with_ros_configuration():
    rc, errors = flake8_main_with_errors(argv=_paths())
    assert rc == 0, f'{len(errors)} flake8 findings:\n' + '\n'.join(errors)


@pytest.mark.linter
def test_pep257_with_ros_configuration(capsys):
    rc = pep257_main(argv=_paths())
    assert rc == 0, 'pep257 findings:\n' + capsys.readouterr().out


@pytest.mark.linter
def test_every_source_file_carries_the_copyright_and_license_header():
    missing = []
    for path in _sources():
        comment = '//' if path.suffix == '.ts' else '#'
        lines = path.read_text(encoding='utf-8').splitlines()
        if lines and lines[0].startswith('#!'):
            lines = lines[1:]
        expected = [f'{comment} {COPYRIGHT}', comment] + [
            f'{comment} {line}'.rstrip() for line in APACHE_HEADER
        ]
        if lines[: len(expected)] != expected:
            missing.append(str(path.relative_to(REPO)))
    # the glob found the package, tests and tools (about 190 files), not an empty or partial tree
    assert len(_sources()) > 150
    assert missing == [], f'without the copyright and license header: {missing}'


@pytest.mark.linter
def test_the_license_file_is_the_apache_2_0_text():
    text = (REPO / 'LICENSE').read_text(encoding='utf-8')
    assert 'Apache License' in text and 'Version 2.0, January 2004' in text
    assert 'END OF TERMS AND CONDITIONS' in text
