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
The architecture: the rooms of the package and of its core, checked by import-linter.

setup.cfg's [importlinter] contracts say which room may import which (a room imports only rooms
below it), that no import cycle joins the modules of a room or the rooms themselves, and that the
core never imports ROS; ``lint-imports`` (import-linter's own command, not ours) checks them over
every import, deferred ones included.
"""

import configparser
from pathlib import Path
import subprocess
import sys

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / 'torquefree_ros'
# folders of the package that hold data, not code: no contract needs to place them
DATA_FOLDERS = {'scenes', 'interfaces', '__pycache__'}


def _contracts() -> configparser.ConfigParser:
    config = configparser.ConfigParser()
    config.read(ROOT / 'setup.cfg')
    return config


def _layers(section: str) -> set[str]:
    text = _contracts()[section]['layers']
    return {
        name.strip()
        for line in text.split('\n')
        for name in line.split('|')
        if name.strip()
    }


def _rooms(folder: Path) -> set[str]:
    """Return the subpackages and modules of ``folder``: what a contract must place."""
    packages = {
        path.name
        for path in folder.iterdir()
        if path.is_dir() and path.name not in DATA_FOLDERS and (path / '__init__.py').exists()
    }
    modules = {path.stem for path in folder.glob('*.py') if path.stem != '__init__'}
    return packages | modules


def test_lint_imports_keeps_every_contract():
    lint_imports = Path(sys.executable).with_name('lint-imports')
    result = subprocess.run(
        [str(lint_imports), '--no-cache'],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'Contracts: 4 kept, 0 broken.' in result.stdout, result.stdout


def test_every_room_of_the_package_is_in_its_layers():
    layers = _layers('importlinter:contract:package')
    placed = {name.removeprefix('torquefree_ros.') for name in layers}
    assert placed == _rooms(PACKAGE)


def test_every_room_of_the_core_is_in_its_layers():
    assert _layers('importlinter:contract:core') == _rooms(PACKAGE / 'core')


def test_every_output_has_an_encoder_for_its_message_layout():
    from torquefree_ros.bag.layouts import LAYOUTS
    from torquefree_ros.core.effects import EFFECTS, OutputEffect

    outputs = [effect for effect in EFFECTS.values() if issubclass(effect, OutputEffect)]
    assert outputs
    assert {output.name: output.layout in LAYOUTS for output in outputs} == {
        output.name: True for output in outputs
    }
