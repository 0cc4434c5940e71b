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
Reading files that anyone may have written (scene files, a bag's metadata.yaml) totally.

Only a regular file below a size bound is read (a FIFO or a device is refused before it can block),
and a YAML document is refused if it nests too deeply or expands, through aliases, into too many
values ("billion laughs"). Every failure is a ``ValueError`` whose text says what and where.
"""

from __future__ import annotations

import os
from pathlib import Path
import stat

import yaml

MAX_YAML_NODES = 100_000  # values after alias expansion
MAX_YAML_DEPTH = 64  # nesting levels; PyYAML recurses once per level


def read_regular_file(path: Path, max_bytes: int) -> bytes:
    """
    Return the bytes of a regular file of at most ``max_bytes``.

    ``OSError`` as from ``open``, ``ValueError`` for a special file or one too large.
    """
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, 'O_CLOEXEC', 0))
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            raise ValueError(f"'{clip(str(path))}' is not a regular file")
        with os.fdopen(descriptor, 'rb', closefd=False) as stream:
            data = stream.read(max_bytes + 1)
    finally:
        os.close(descriptor)
    if len(data) > max_bytes:
        raise ValueError(f"'{clip(str(path))}' is larger than {max_bytes:,} bytes")
    return data


def check_regular_file(path: Path) -> None:
    """``ValueError`` unless ``path`` is a regular file (checked without opening it)."""
    if not stat.S_ISREG(os.stat(path).st_mode):
        raise ValueError(f"'{clip(str(path))}' is not a regular file")


def load_yaml(text: str, where: str, loader_class=yaml.SafeLoader):
    """``yaml.load`` with bounds; errors say ``where:LINE:COLUMN: not valid YAML: ...``."""
    loader = None
    try:
        loader = loader_class(text)
        node = loader.get_single_node()
        if node is None:
            return None
        _check_node_size(node, where)
        return loader.construct_document(node)
    except yaml.reader.ReaderError as error:  # a character YAML does not allow
        line = text.count('\n', 0, error.position) + 1
        column = error.position - (text.rfind('\n', 0, error.position) + 1) + 1
        raise ValueError(
            f'{where}:{line}:{column}: not valid YAML: character #x{error.character:04x} is not '
            'allowed'
        ) from None
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        at = f'{where}:{mark.line + 1}:{mark.column + 1}' if mark is not None else where
        what = '; '.join(clip(part) for part in (error.context, error.problem) if part)
        raise ValueError(f'{at}: not valid YAML: {what}') from None
    except yaml.YAMLError as error:
        raise ValueError(f'{where}: not valid YAML: {clip(str(error))}') from None
    except RecursionError:
        raise ValueError(
            f'{where}: not valid YAML: nested too deeply (more than {MAX_YAML_DEPTH} levels)'
        ) from None
    except (KeyError, IndexError, TypeError, OverflowError) as error:
        # PyYAML's constructors on odd scalars
        raise ValueError(
            f'{where}: not valid YAML: a value cannot be read ({type(error).__name__}: '
            f'{clip(str(error))})'
        ) from None
    except ValueError as error:
        if str(error).startswith(where):
            raise
        raise ValueError(
            f'{where}: not valid YAML: a value cannot be read ({clip(str(error))})'
        ) from None
    finally:
        if loader is not None:
            loader.dispose()


def _check_node_size(root, where: str) -> None:
    """
    Raise ``ValueError`` if the YAML tree under ``root`` nests too deeply or has too many values.

    The values are counted with a memo over shared (aliased) nodes, so the count itself stays
    cheap.
    """
    sizes: dict[int, int] = {}
    depths: dict[int, int] = {}

    def visit(node, depth: int) -> int:
        if depth > MAX_YAML_DEPTH:
            mark = node.start_mark
            raise ValueError(
                f'{where}:{mark.line + 1}:{mark.column + 1}: nested too deeply '
                f'(more than {MAX_YAML_DEPTH} levels)'
            )
        key = id(node)
        if key in sizes and depths[key] <= depth:
            return sizes[key]
        depths[key] = depth
        if isinstance(node, yaml.SequenceNode):
            children = node.value
        elif isinstance(node, yaml.MappingNode):
            children = [part for pair in node.value for part in pair]
        else:
            children = []
        size = 1
        for item in children:
            size += visit(item, depth + 1)
            if size > MAX_YAML_NODES:
                raise ValueError(
                    f'{where}: too large once its aliases are expanded (more than '
                    f'{MAX_YAML_NODES:,} values)'
                )
        sizes[key] = size
        return size

    visit(root, 0)


def clip(text: str, limit: int = 160) -> str:
    """Error messages quote at most this much of an input."""
    return text if len(text) <= limit else text[:limit] + f'… ({len(text)} characters)'
