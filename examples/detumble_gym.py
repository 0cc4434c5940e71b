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
Detumble the library scene `detumble` through the Gymnasium environment (needs the 'gym' extra).

The reward (torquefree_ros.plant.gym.DetumbleReward), with h = 1 / rate:

    r_k = -h * ( |omega_B(t_k+1)|^2 / |omega_0|^2 + 0.1 * |tau_k|^2 / max_torque^2 )

so the return is minus the quadratic cost integrated over the episode: about -1 a second for the
tumble left alone. The episode terminates when |omega_B| < 1e-3 rad/s, and is truncated after
max_steps.

    python examples/detumble_gym.py [--gain K] [--rate HZ]
"""

import argparse

import numpy as np
from torquefree_ros.plant.gym import AttitudeEnv


def episode(env, gain, seed=None):
    """
    Run one episode of the rate-damping controller tau = -K omega_B.

    The env clips the torque to the box.
    """
    obs, _ = env.reset(seed=seed)
    total, steps, terminated, truncated = 0.0, 0, False, False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(-gain * obs[:3])
        total, steps = total + reward, steps + 1
    return total, steps, terminated, info['t'], np.linalg.norm(obs[:3])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument(
        '--gain', type=float, default=0.04, help='K of tau = -K omega_B, N m s (default 0.04)'
    )
    parser.add_argument('--rate', type=float, default=10.0, help='control rate, Hz (default 10)')
    args = parser.parse_args(argv)
    env = AttitudeEnv('detumble', args.rate, max_steps=int(60 * args.rate))
    total, steps, terminated, t, omega = episode(env, args.gain)
    ended = 'terminated' if terminated else 'truncated'
    print(
        f'K = {args.gain:g} N m s at {args.rate:g} Hz: {ended} after '
        f'{steps} steps ({t:.1f} s), |omega| = {omega:.2e} rad/s, return {total:.4f}'
    )
    idle, *_ = episode(env, 0.0)
    print(f'no torque for the same 60 s: return {idle:.4f}')


if __name__ == '__main__':
    main()
