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
Bodies built from parts: boxes, cylinders, spheres and point masses.

Each part has a mass, a size, a position and an orientation in the body frame; the parts are
combined about the composite centre of mass by the parallel axis theorem (seed 002: find the new
centre of mass, add the parts' own inertias rotated into the body frame, add
``m (|d|^2 1 - d d^T)`` for each part's offset ``d`` from it).

The body frame of a scene made of parts is the frame the parts are written in, moved to the
composite centre of mass; the tensor is generally not diagonal there, and :class:`RigidBody`
diagonalises it, as for a scene that gives a full tensor.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks.schema import boolean, child, fields, number, one_key, orientation, Param, vector
from ..frames import quaternion


def _box(mass, size):
    a, b, c = size
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def _cylinder(mass, radius, length):
    """Axis along the part's z axis."""
    transverse = mass * (3.0 * radius * radius + length * length) / 12.0
    return np.diag([transverse, transverse, 0.5 * mass * radius * radius])


def _sphere(mass, radius, hollow):
    return (2.0 / 3.0 if hollow else 0.4) * mass * radius * radius * np.eye(3)


_PLACEMENT = {
    'position': Param(vector(3, unit='m'), np.zeros(3)),
    'orientation': Param(orientation(), np.array([0.0, 0.0, 0.0, 1.0])),
}
_MASS = {'mass': Param(number(positive=True, unit='kg'))}
#: part name -> (parameters, own inertia about the part's centre in the part's frame)
PART_KINDS = {
    'box': (
        {
            **_MASS,
            'size': Param(
                vector(3, unit='m', positive=True), description='edge lengths [x, y, z], m'
            ),
        },
        lambda v: _box(v['mass'], v['size']),
    ),
    'cylinder': (
        {
            **_MASS,
            'radius': Param(number(positive=True, unit='m')),
            'length': Param(number(positive=True, unit='m')),
        },
        lambda v: _cylinder(v['mass'], v['radius'], v['length']),
    ),
    'sphere': (
        {
            **_MASS,
            'radius': Param(number(positive=True, unit='m')),
            'hollow': Param(boolean, False),
        },
        lambda v: _sphere(v['mass'], v['radius'], v['hollow']),
    ),
    'point_mass': (dict(_MASS), lambda v: np.zeros((3, 3))),
}


# the placement keys are accepted by every kind
for _params, _ in PART_KINDS.values():
    _params.update(_PLACEMENT)


@dataclass(frozen=True)
class Part:
    kind: str
    mass: float  # kg
    position: np.ndarray  # of its centre, body frame, m
    inertia: np.ndarray  # about its own centre, in the body frame (already rotated), kg m^2


@dataclass(frozen=True)
class Composite:
    mass: float  # kg
    center_of_mass: np.ndarray  # in the frame the parts are written in, m
    tensor: np.ndarray  # about the centre of mass, axes of that frame, kg m^2


def parse_part(entry, path: str) -> Part:
    kind, parameters = one_key(entry, path, PART_KINDS, 'part')
    params, own_inertia = PART_KINDS[kind]
    values = fields(parameters, child(path, kind), params)
    rotation = quaternion.to_matrix(values['orientation'])
    return Part(
        kind, values['mass'], values['position'], rotation @ own_inertia(values) @ rotation.T
    )


def combine(parts) -> Composite:
    """Mass, centre of mass and inertia tensor about it (parallel axis theorem)."""
    masses = np.array([part.mass for part in parts])
    positions = np.array([part.position for part in parts])
    total = float(masses.sum())
    center = masses @ positions / total
    tensor = np.zeros((3, 3))
    for part in parts:
        d = part.position - center
        tensor += part.inertia + part.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return Composite(total, center, 0.5 * (tensor + tensor.T))


def tensor_elements(tensor: np.ndarray) -> tuple:
    """``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` of a symmetric tensor (the scene's 6-element form)."""
    return tuple(
        float(x)
        for x in (
            tensor[0, 0],
            tensor[1, 1],
            tensor[2, 2],
            tensor[0, 1],
            tensor[0, 2],
            tensor[1, 2],
        )
    )
