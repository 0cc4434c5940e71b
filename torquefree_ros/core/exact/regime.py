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
The kind of torque-free motion a state starts (seeds 000 and 002).

Rest, a sphere, a pure spin (stable or not), the axisymmetric cones, the polhodes about the major
and minor axes and the separatrix between them, with the periods and angles each has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .polhode import solve_polhode

# Moments closer than this (relative) are *labelled* equal in the regime report; the propagators
# never use it: their formulas stay exact as two moments approach each other.
EQUAL_MOMENTS_RTOL = 1e-12


@dataclass(frozen=True)
class MotionRegime:
    """
    What kind of torque-free motion a state starts.

    Periods are in seconds (``inf`` where the motion never repeats, ``nan`` where the notion does
    not apply).
    """

    kind: str  # at_rest | sphere | pure_spin | axisymmetric_oblate | axisymmetric_prolate |
    #            major_axis_polhode | minor_axis_polhode | separatrix
    axis: str = ''  # for pure_spin: major | intermediate | minor | symmetric-plane
    stability: str = ''  # for pure_spin: "marginally stable" or "unstable" (seed 002)
    polhode_period: float = float('nan')  # period of the body rates
    flip_period: float = float('nan')  # time between reversals of the intermediate-axis rate
    precession_rate: float = float('nan')  # axisymmetric: w_p = (I3/IT - 1) w3 (seed 000)
    separatrix_distance: float = float('nan')  # (H^2/2T - I_mid) / I_mid
    body_cone_angle: float = float('nan')  # axisymmetric: between w and the symmetry axis, rad
    space_cone_angle: float = float('nan')  # axisymmetric: between w and H, rad
    # axisymmetric: symmetry axis about H_N, |H|/I_T
    inertial_precession_rate: float = float('nan')

    def summary(self) -> str:
        parts = [self.kind.replace('_', ' ')]
        if self.axis:
            parts.append(f'about the {self.axis} axis ({self.stability})')
        for label, value in (
            ('polhode period', self.polhode_period),
            ('flip period', self.flip_period),
            ('body-frame precession rate', self.precession_rate),
        ):
            if not np.isnan(value):
                parts.append(f'{label} {value:.6g}' + (' rad/s' if 'rate' in label else ' s'))
        if not np.isnan(self.body_cone_angle):
            parts.append(
                f'body cone angle {np.degrees(self.body_cone_angle):.6g} deg, space cone angle '
                f'{np.degrees(self.space_cone_angle):.6g} deg, symmetry axis precesses about H at '
                f'{self.inertial_precession_rate:.6g} rad/s'
            )
        return ', '.join(parts)


def _angle(vector: np.ndarray, axial: float, axis: int) -> float:
    """Acute angle between ``vector`` and the line of principal axis ``axis``."""
    transverse = float(np.linalg.norm(np.delete(vector, axis)))
    return float(np.arctan2(transverse, axial))


def _angle_between(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))


def classify_motion(body, omega_B) -> MotionRegime:
    """
    Classify the torque-free motion of ``body`` starting at ``omega_B`` (seed 000 and 002).

    ``body``: a :class:`~torquefree_ros.core.body.rigid_body.RigidBody` (its moments, principal
    frame and invariants).
    """
    omega_P = body.to_principal(omega_B)
    moments = body.moments
    lo, mid, hi = np.argsort(moments, kind='stable')
    scale = float(np.max(moments))
    equal_lo = moments[mid] - moments[lo] <= EQUAL_MOMENTS_RTOL * scale
    equal_hi = moments[hi] - moments[mid] <= EQUAL_MOMENTS_RTOL * scale
    if not np.any(omega_P):
        return MotionRegime('at_rest')
    if equal_lo and equal_hi:
        return MotionRegime('sphere')
    gaps = body.momentum_energy_gaps(omega_B)
    two_T = float(2.0 * body.kinetic_energy(omega_B))
    distance = float(gaps[mid] / (two_T * moments[mid]))
    polhode = solve_polhode(moments, omega_P)
    if polhode is None:
        axis_index = int(np.argmax(np.abs(omega_P)))
        if (equal_lo and axis_index in (lo, mid)) or (equal_hi and axis_index in (mid, hi)):
            axis = 'symmetric-plane'
        else:
            axis = {lo: 'minor', mid: 'intermediate', hi: 'major'}[axis_index]
        stable = 'unstable' if axis == 'intermediate' else 'marginally stable'
        return MotionRegime('pure_spin', axis, stable, separatrix_distance=distance)
    period = polhode.polhode_period
    if equal_lo or equal_hi:
        symmetry_axis = hi if equal_lo else lo
        transverse = moments[mid]
        precession = (moments[symmetry_axis] / transverse - 1.0) * float(omega_P[symmetry_axis])
        kind = 'axisymmetric_oblate' if equal_lo else 'axisymmetric_prolate'
        # The cones of seed 000: the body cone is swept by w about the symmetry axis, the space
        # cone by w about H; the symmetry axis precesses about H_N at |H| / I_transverse.
        axial = abs(float(omega_P[symmetry_axis]))
        H_P = moments * omega_P
        return MotionRegime(
            kind,
            polhode_period=period,
            precession_rate=precession,
            body_cone_angle=_angle(omega_P, axial, symmetry_axis),
            space_cone_angle=_angle_between(omega_P, H_P),
            inertial_precession_rate=float(np.linalg.norm(H_P)) / transverse,
        )
    if polhode.jacobi.mc == 0.0:
        kind = 'separatrix'
    else:
        kind = 'major_axis_polhode' if gaps[mid] > 0.0 else 'minor_axis_polhode'
    return MotionRegime(
        kind, polhode_period=period, flip_period=0.5 * period, separatrix_distance=distance
    )
