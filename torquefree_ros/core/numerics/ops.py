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
Arithmetic on one body's numbers or on many bodies', behind one set of names.

One body's numbers are plain Python floats, many bodies' are numpy arrays (one element per body).
Constants are written once and computed either way with the same IEEE operations in the same order:
``+ - * /`` and ``sqrt`` are correctly rounded in Python and numpy alike, ``copysign``,
``min``/``max`` and selections are exact, scipy's Carlson integrals are one C function per element,
and ``atan2``, ``hypot``, ``exp``, ``sin`` and the like are Python's ``math`` functions for both
(numpy may vectorise its own). A body computed among many is bit for bit the body alone.
"""

from __future__ import annotations

import math
import operator

import numpy as np
from scipy.special import elliprf, elliprj


class _Floats:
    """Operations on one body: plain Python floats."""

    sqrt = staticmethod(math.sqrt)
    copysign = staticmethod(math.copysign)
    atan2 = staticmethod(math.atan2)
    exp = staticmethod(math.exp)
    expm1 = staticmethod(math.expm1)
    sin = staticmethod(math.sin)
    cos = staticmethod(math.cos)
    sinh = staticmethod(math.sinh)

    @staticmethod
    def where(condition, if_true, if_false):
        return if_true if condition else if_false

    @staticmethod
    def clip(value, low: float, high: float):
        return min(max(value, low), high)

    pick = staticmethod(operator.getitem)  # pick(values, index)
    choose = staticmethod(operator.getitem)  # choose(tuples, index): one of several tuples
    hypot = staticmethod(math.hypot)

    @staticmethod
    def order(values):
        return sorted(range(3), key=values.__getitem__)  # stable

    @staticmethod
    def first_largest(values):
        return values.index(max(values))

    @staticmethod
    def elliprf(x, y, z):
        return float(elliprf(x, y, z))

    @staticmethod
    def elliprj(x, y, z, p):
        return float(elliprj(x, y, z, p))


def _per_element(function):
    """
    Make ``function`` (one of ``math``'s) apply element by element to arrays over bodies.

    Each element is computed as for one body.
    """

    def apply(*arrays):
        result = [function(*values) for values in zip(*(np.ravel(a).tolist() for a in arrays))]
        return np.array(result, dtype=float).reshape(np.shape(arrays[0]))

    return apply


class _Columns:
    """Operations on many bodies: each value a numpy array over bodies."""

    sqrt = staticmethod(np.sqrt)
    copysign = staticmethod(np.copysign)
    where = staticmethod(np.where)
    elliprf = staticmethod(elliprf)
    elliprj = staticmethod(elliprj)

    atan2 = staticmethod(_per_element(math.atan2))
    hypot = staticmethod(_per_element(math.hypot))
    exp = staticmethod(_per_element(math.exp))
    expm1 = staticmethod(_per_element(math.expm1))
    sin = staticmethod(_per_element(math.sin))
    cos = staticmethod(_per_element(math.cos))
    sinh = staticmethod(_per_element(math.sinh))

    @staticmethod
    def clip(value, low: float, high: float):
        return np.minimum(np.maximum(value, low), high)

    @staticmethod
    def pick(values, index):
        return np.choose(index, values)

    @staticmethod
    def choose(tuples, index):
        return tuple(np.choose(index, values) for values in zip(*tuples))

    @staticmethod
    def order(values):
        return tuple(np.argsort(np.stack(values, axis=-1), axis=-1, kind='stable').T)

    @staticmethod
    def first_largest(values):
        return np.argmax(np.stack(values), axis=0)


FLOATS = _Floats()
COLUMNS = _Columns()
