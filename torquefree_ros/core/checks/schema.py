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
A small declarative schema for scene files.

Each field is a checker that converts a YAML value or raises :class:`FieldError` with the field's
path (``effects[1].torque``) and the reason.

A mapping is checked against a dict of :class:`Param` (checker + default); an unknown key is named
with the nearest valid one, a missing required key is named as missing.
"""

from __future__ import annotations

from dataclasses import dataclass
import difflib
import math
import re
from typing import Any, Callable

import numpy as np

from . import validation
from ...files.safe_files import clip

Checker = Callable[[Any, str], Any]
REQUIRED = object()


class FieldError(ValueError):
    """A field that cannot be used: ``path`` names it, the message says why."""

    def __init__(self, path: str, reason: str):
        super().__init__(f'{path or "(top level)"}: {reason}')
        self.path = path
        self.reason = reason


@dataclass(frozen=True)
class Param:
    check: Checker
    default: Any = REQUIRED
    description: str = ''


# characters of a bad value quoted in an error: enough to recognise it, never a flood
MAX_SHOWN = 80


def shown(value) -> str:
    """``repr(value)``, clipped: a bad value in an error message stays one readable line."""
    return clip(repr(value), MAX_SHOWN)


def child(path: str, key) -> str:
    if isinstance(key, int):
        return f'{path}[{key}]'
    key = clip(str(key), MAX_SHOWN)
    return f'{path}.{key}' if path else key


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite(value) -> bool:
    """
    Tell whether ``value`` is a finite real number as float64.

    An integer of 400 digits is not: float() overflows.
    """
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _type_name(value) -> str:
    return {
        dict: 'mapping',
        list: 'list',
        str: 'string',
        bool: 'boolean',
        type(None): 'nothing',
    }.get(type(value), type(value).__name__)


def number(
    minimum: float | None = None,
    maximum: float | None = None,
    *,
    positive: bool = False,
    unit: str = '',
) -> Checker:
    """Build a checker of a finite real number in ``[minimum, maximum]`` (``positive``: > 0)."""
    suffix = f' {unit}' if unit else ''

    def check(value, path):
        if not _is_number(value) or not _finite(value):
            raise FieldError(path, f'expected a finite number{suffix}, got {shown(value)}')
        if positive and value <= 0:
            raise FieldError(path, f'must be > 0{suffix}, got {shown(value)}')
        if minimum is not None and value < minimum:
            raise FieldError(path, f'must be >= {minimum:g}{suffix}, got {shown(value)}')
        if maximum is not None and value > maximum:
            raise FieldError(path, f'must be <= {maximum:g}{suffix}, got {shown(value)}')
        return float(value)

    return check


def integer(minimum: int | None = None, maximum: int | None = None) -> Checker:
    def check(value, path):
        if not isinstance(value, int) or isinstance(value, bool):
            raise FieldError(path, f'expected an integer, got {shown(value)}')
        if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
            raise FieldError(path, f'must lie in [{minimum}, {maximum}], got {shown(value)}')
        return value

    return check


def text(*, allow_empty: bool = False) -> Checker:
    def check(value, path):
        if not isinstance(value, str) or (not allow_empty and not value.strip()):
            raise FieldError(
                path, f'expected a{"" if allow_empty else " non-empty"} string, got {shown(value)}'
            )
        return value

    return check


def boolean(value, path):
    if not isinstance(value, bool):
        raise FieldError(path, f'expected true or false, got {shown(value)}')
    return value


_TOPIC = re.compile(r'^~?/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$')


def topic_name(value, path):
    """
    Check a ROS topic name (relative or absolute).

    Tokens of letters, digits and '_', not starting with a digit; at most 256 characters, a limit
    DDS implementations share.
    """
    if not isinstance(value, str) or len(value) > 256 or not _TOPIC.match(value):
        raise FieldError(
            path, f"expected a ROS topic name such as 'imu' or '/sensors/imu', got {shown(value)}"
        )
    return value


def retired(reason: str) -> Checker:
    """
    Build the checker of a key that is no longer used.

    Any value is refused with ``reason`` (what replaced it, what to do), so an old scene file fails
    with an explanation rather than an "unknown key" guess.
    """

    def check(value, path):
        raise FieldError(path, f'no longer used: {reason}')

    return check


def choice(*options: str) -> Checker:
    def check(value, path):
        if value not in options:
            close = difflib.get_close_matches(str(value), options, n=1)
            hint = f'; did you mean {close[0]!r}?' if close else ''
            raise FieldError(
                path, f'expected one of {", ".join(options)}, got {shown(value)}{hint}'
            )
        return value

    return check


def vector(*lengths: int, unit: str = '', positive: bool = False) -> Checker:
    """Build a checker of a list of ``lengths`` finite numbers, as a float array."""
    wanted = ' or '.join(str(n) for n in lengths)

    def check(value, path):
        if not isinstance(value, (list, tuple)) or not all(_is_number(x) for x in value):
            raise FieldError(
                path,
                f'expected a list of {wanted} numbers{f" ({unit})" if unit else ""}, '
                f'got {shown(value)}',
            )
        if len(value) not in lengths:
            raise FieldError(path, f'expected {wanted} numbers, got {len(value)}')
        if not all(_finite(x) for x in value):
            raise FieldError(path, f'every entry must be finite, got {shown(list(value))}')
        array = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(array)):
            raise FieldError(path, f'every entry must be finite, got {shown(list(value))}')
        if positive and np.any(array <= 0):
            raise FieldError(path, f'every entry must be > 0, got {shown(list(value))}')
        return array

    return check


def orientation() -> Checker:
    """
    Build a checker of an ``(x, y, z, w)`` quaternion, normalised by the core's own check.

    Zero and far-from-unit norms are refused.
    """
    as_vector = vector(4)

    def check(value, path):
        try:
            return validation.unit_quaternion(as_vector(value, path), path)
        except ValueError as error:
            raise FieldError(path, str(error).split(': ', 1)[-1]) from None

    return check


def listing(item: Checker, *, min_length: int = 0) -> Checker:
    def check(value, path):
        if not isinstance(value, list):
            raise FieldError(path, f'expected a list, got {_type_name(value)}')
        if len(value) < min_length:
            raise FieldError(path, f'expected at least {min_length} entries, got {len(value)}')
        return [item(entry, child(path, index)) for index, entry in enumerate(value)]

    return check


def mapping(params: dict[str, Param]) -> Checker:
    return lambda value, path: fields(value, path, params)


def fields(value, path: str, params: dict[str, Param]) -> dict:
    """
    Check a mapping against ``params``; return every key, defaults filled.

    ``None`` stays for an optional key without a default.
    """
    if not isinstance(value, dict):
        keys = ', '.join(params)
        raise FieldError(path, f'expected a mapping (keys: {keys}), got {_type_name(value)}')
    check_keys(value, params, path)
    result = {}
    for key, param in params.items():
        if key in value:
            result[key] = param.check(value[key], child(path, key))
        elif param.default is REQUIRED:
            raise FieldError(
                child(path, key),
                'missing' + (f' ({param.description})' if param.description else ''),
            )
        else:
            result[key] = param.default
    return result


def check_keys(value: dict, allowed, path: str) -> None:
    allowed = tuple(allowed)
    for key in value:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = (
                f'; did you mean {close[0]!r}?' if close else f' (allowed: {", ".join(allowed)})'
            )
            raise FieldError(child(path, key), f'unknown key{hint}')


def one_key(value, path: str, known, what: str) -> tuple[str, Any]:
    """Split a ``- NAME: {parameters}`` entry into its name (one of ``known``) and parameters."""
    if not (isinstance(value, dict) and len(value) == 1):
        raise FieldError(
            path, f"expected a one-key mapping '- NAME: {{parameters}}' naming a {what}"
        )
    ((name, parameters),) = value.items()
    if name not in known:
        close = difflib.get_close_matches(str(name), tuple(known), n=1)
        hint = f'; did you mean {close[0]!r}?' if close else ''
        raise FieldError(
            path, f'unknown {what} {shown(name)}{hint} (known: {", ".join(sorted(known))})'
        )
    return name, ({} if parameters is None else parameters)
