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
The bounds on integration work that every integrator shares, compiled or not, and their errors.

``propagator`` in the errors is the propagator that refused (its ``name`` and
``max_steps_per_sample``), so both paths refuse in the same words.
"""

#: integrator steps one sample (one requested time after the previous) may take: about a second of
#: the slowest path (rk4 in Python with effects), ~10 ms compiled. The node, the offline tools and
#: the API all refuse more, with the same reason, so no call can hang on a scene that needs
#: ~forever
MAX_STEPS_PER_SAMPLE = 10_000


class StepBudgetExceeded(RuntimeError):
    """A sample needs more integrator steps than ``Propagator.max_steps_per_sample``."""

    def __init__(self, propagator, t: float, step: float):
        super().__init__(
            f'{propagator.name}: reaching t = {t:.6g} s needs more than '
            f'{propagator.max_steps_per_sample:,} steps from the sample before '
            f'(the step is {step:.2g} s), the bound per sample that keeps the node responsive: '
            'raise the sample rate, or relax the accuracy (a longer step, looser tolerances)'
        )


class StepTooSmall(RuntimeError):
    """
    The adaptive step fell below what float64 resolves at ``t``.

    This is scipy's "Required step size is less than spacing between numbers": the motion is too
    fast there, or has overflowed.
    """

    def __init__(self, propagator, t: float):
        super().__init__(
            f'{propagator.name}: at t = {t:.6g} s the step fell under 10 rounding units of t: '
            'the motion there is too fast or too stiff for float64 steps, or has overflowed '
            "(check the scene's rates, torques and effect parameters)"
        )
