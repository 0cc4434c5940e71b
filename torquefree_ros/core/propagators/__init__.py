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

"""Propagator registry: every propagator behind one interface, looked up by name."""

from . import analytic, gyrostat, numerical  # noqa: F401  (registers the propagators)
from .base import Propagator, propagator_class, PROPAGATORS
from ..body.rigid_body import RigidBody
from ..checks.validation import finite_vector
from ..exact.regime import (
    classify_gyrostat,
    classify_oblique_gyrostat,
    GyrostatRegime,
    MotionRegime,
)
from ..numerics.steps import MAX_STEPS_PER_SAMPLE, StepBudgetExceeded, StepTooSmall

__all__ = [
    'MAX_STEPS_PER_SAMPLE',
    'PROPAGATORS',
    'ATOL_PER_RTOL',
    'DEFAULT_ACCURACY',
    'Propagator',
    'StepBudgetExceeded',
    'StepTooSmall',
    'propagator_class',
    'make_propagator',
    'motion_regime',
]

#: the integrator tolerance (relative, per step) of ``auto`` for a scene with effects
DEFAULT_ACCURACY = 1e-10
# auto's absolute tolerance, relative to the accuracy: the rtol/atol pair of scipy's tight settings
ATOL_PER_RTOL = 1e-2


def make_propagator(
    body,
    angular_velocity,
    orientation,
    propagator: str = 'auto',
    effects=(),
    accuracy: float | None = None,
    **options,
) -> Propagator:
    """
    Build a propagator by name.

    ``auto`` is the exact solution when no effect changes the motion, the exact free gyrostat
    (``gyrostat``) when the only ones are ``rotor`` effects and coasting ``reaction_wheels``
    (:func:`.gyrostat.free_gyrostat`: their summed momentum along a principal axis, to
    :data:`.gyrostat.ROTOR_AXIS_TOLERANCE`, or oblique, or zero: the free body with the inertia
    less the wheels' spin) but for an oblique state the closed form refuses (exactly on a
    separatrix, or a momentum beyond :data:`.gyrostat.OBLIQUE_MOMENTUM_RATIO` times the body's),
    else DOP853 held to ``accuracy`` (``rtol``;
    ``atol = accuracy / 100``; default :data:`DEFAULT_ACCURACY`). ``effects``: motion effects only
    (outputs never reach a propagator).
    """
    effects = tuple(effects)
    if propagator != 'auto':
        return propagator_class(propagator)(
            body, angular_velocity, orientation, effects, **options
        )
    if not effects:
        return propagator_class('analytic')(body, angular_velocity, orientation, **options)
    found = gyrostat.free_gyrostat(
        RigidBody.from_inertia(body), effects, finite_vector(angular_velocity, 'angular_velocity')
    )
    if not isinstance(found, str):
        return propagator_class('gyrostat')(
            body, angular_velocity, orientation, effects, **options
        )
    tolerance = DEFAULT_ACCURACY if accuracy is None else accuracy
    options = {'rtol': tolerance, 'atol': tolerance * ATOL_PER_RTOL, **options}
    return propagator_class('dop853')(body, angular_velocity, orientation, effects, **options)


def motion_regime(propagator: Propagator) -> MotionRegime | GyrostatRegime:
    """
    Return the regime of the motion a propagator's initial state starts.

    A free gyrostat's (rotors and coasting wheels, whichever propagator runs it:
    :func:`.gyrostat.free_gyrostat`) is the gyrostat's own, with its equilibria and separatrices:
    along a principal axis :func:`.exact.regime.classify_gyrostat`, oblique
    :func:`.exact.regime.classify_oblique_gyrostat` (its period, equilibria and separatrix
    distance; what the motion circles unnamed), an oblique state the closed form refuses
    included (``auto`` integrates it, but it is a gyrostat all the same); at ``h = 0`` the free
    body's with the inertia less the wheels' spin. Any other scene's is the torque-free regime of
    the body at the initial rates (:meth:`RigidBody.classify`), which effects that change the
    motion make a reading of the start only.
    """
    omega0 = propagator.omega0_B
    parts = gyrostat.gyrostat_parts(propagator.body, propagator.effects, omega0)
    if isinstance(parts, str):
        return propagator.body.classify(omega0)
    found = gyrostat.free_gyrostat(propagator.body, propagator.effects, omega0)
    if isinstance(found, str) or found.oblique:
        inertia, h_B = parts[0], parts[1]
        return classify_oblique_gyrostat(
            inertia.moments, inertia.to_principal(omega0), h_B @ inertia.principal_axes
        )
    if found.momentum == 0.0:  # the free body with the inertia less the wheels' spin
        return found.inertia.classify(omega0)
    inertia = found.inertia
    omega_P = inertia.to_principal(omega0)
    return classify_gyrostat(inertia.moments, omega_P, found.axis, found.momentum)
