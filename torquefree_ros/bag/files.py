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
A bag's directory and files.

The bag error, rosbag2's names, creating a bag's directory safely and replacing a small file whole.

Used by the reader and the writer alike, so neither imports the other for these.
"""

from __future__ import annotations

import os
from pathlib import Path
import shutil

from .metadata import METADATA_FILE


class BagError(RuntimeError):
    """A bag that cannot be created, written or read; the message names the path and the reason."""


def mcap_file_name(bag_dir: Path) -> str:
    """rosbag2's name for the first (only) storage file of a bag directory."""
    return f'{bag_dir.name}_0.mcap'


def prepare_bag_directory(path, overwrite: bool = False) -> Path:
    """
    Check that a bag can be created at ``path`` and create its (empty) directory.

    An existing path is refused unless ``overwrite``; even then only a bag directory
    (``metadata.yaml`` and ``.mcap`` files) is replaced, never another directory or a file.
    """
    path = Path(path)
    if not path.name or path.name in ('.', '..'):
        raise BagError(f"bag '{path}': give a directory name for the bag")
    try:
        exists = path.exists() or path.is_symlink()
    except OSError as error:  # a name too long for the file system
        raise BagError(
            f"bag '{str(path)[:120]}…': cannot be created: {error.strerror or error}"
        ) from None
    if exists:
        if not overwrite:
            raise BagError(
                f"bag '{path}': already exists; choose another name or overwrite it explicitly"
            )
        if not _is_bag_directory(path):
            raise BagError(
                f"bag '{path}': exists and is not a bag directory (only metadata.yaml and .mcap "
                f'files), so it is not overwritten'
            )
        shutil.rmtree(path)
    try:
        path.mkdir(parents=True)
    except OSError as error:
        raise BagError(
            f"bag '{path}': cannot create the directory: {error.strerror or error}"
        ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        path.rmdir()
        raise BagError(f"bag '{path}': the directory is not writable")
    return path


def _is_bag_directory(path: Path) -> bool:
    if not path.is_dir() or path.is_symlink():
        return False
    entries = list(path.iterdir())
    return bool(entries) and all(
        entry.is_file() and (entry.name == METADATA_FILE or entry.suffix == '.mcap')
        for entry in entries
    )


def write_atomically(path: Path, text: str) -> None:
    temporary = path.with_name(path.name + '.tmp')
    temporary.write_text(text, encoding='utf-8')
    os.replace(temporary, path)
