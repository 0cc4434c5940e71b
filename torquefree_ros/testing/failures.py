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
The kit's failures and what they say: each names what did not happen, where, and why if known.

:class:`SimulatorTimeout` for a wait that ran out; the texts of every refusal and timeout of the
kit's, built from what the kit saw: the node's run as ``TorqueFreeSim.stepping.state()`` reports it
(``torquefree_ros.ros.sample_loop.StepState``), and the subscriptions the kit watched.
"""

from __future__ import annotations

from typing import Callable


class SimulatorTimeout(TimeoutError):
    """
    A wait of the kit's did not end within its timeout.

    The message names what did not arrive.
    """


def seconds(ns: int | None) -> str:
    """Return a stamp (ns) as seconds with every digit, or ``-`` for none."""
    if ns is None:
        return '-'
    return f'{ns // 1_000_000_000}.{ns % 1_000_000_000:09d} s'


def type_name(message_type) -> str:
    """Return a message class's ROS name (``geometry_msgs/msg/Vector3Stamped``)."""
    module = message_type.__module__.split('.')
    return (
        f'{module[0]}/{module[1]}/{message_type.__name__}'
        if len(module) >= 2
        else message_type.__name__
    )


def node_name(node) -> str:
    return node.get_fully_qualified_name()


def qos_problem(publisher, subscription) -> str:
    """
    Say why ``subscription`` cannot match ``publisher`` (the simulator's, on its topic).

    ``''`` when they can, or when there is no publisher (None).
    """
    from rclpy.qos import qos_check_compatible, QoSCompatibility

    if publisher is None:
        return ''
    compatibility, reason = qos_check_compatible(publisher.qos_profile, subscription.qos_profile)
    if compatibility == QoSCompatibility.ERROR:
        reason = reason.strip().removeprefix('ERROR:').strip().rstrip(';')
        return f" (its QoS cannot match the simulator's publisher: {reason})"
    return ''


# -- refusals of add_node -------------------------------------------------------------------------
def other_context(node, namespace: str) -> str:
    fix = 'context=sim.context' + (
        f" and namespace=sim.namespace ('{namespace}')" if namespace != '/' else ''
    )
    return f"add_node: node '{node.get_name()}' belongs to another context; create it with {fix}"


def elsewhere(node, topic: str, ours: str, namespace: str) -> str:
    """Say that ``topic``, named like the simulator's ``ours`` but not it, can never match."""
    return (
        f"add_node: node '{node.get_name()}' subscribes to {topic}, the simulator publishes "
        f'{ours}: the subscription can never match; create the node with '
        f"namespace=sim.namespace ('{namespace}') or subscribe to the full name"
    )


# -- the loop and the samples ---------------------------------------------------------------------
def loop_problem(state, simulation) -> str:
    """Say why the node cannot publish the kit's run ``simulation`` at all (``''``: it can)."""
    if state.failure:
        return f'the simulation stopped: {state.failure}'
    if state.paused_at:
        return f'the simulator is paused (at {state.paused_at}): ~/pause false resumes it'
    if state.simulation is not simulation:
        return (
            "the simulator was reset behind the kit's back (its ~/reset service): "
            'use sim.reset()'
        )
    return ''


def lockstep_wait(k: int, simulation, state, resolve: Callable[[str], str]) -> str:
    """Say what a lock-step node waited for before sample ``k`` of ``simulation``, in vain."""
    stamp = simulation.stamp_ns(k - 1)
    holds = simulation.command_holds
    # the topics still unanswered (a scene may take torque and wheel commands: each must answer)
    waiting = [effect for effect, hold in holds if not hold.answered(stamp)] or [
        effect for effect, _ in holds
    ]
    topics = ', '.join(resolve(effect.topic) for effect in waiting)
    answer = seconds(stamp)
    return (
        f'in lock-step it waits for a command stamped {answer} or later on {topics} '
        f'(the answer to sample {k - 1}) and none came within lockstep_timeout '
        f'({state.request.lockstep_timeout:g} s); for an open loop pass lockstep=False'
    )


def missed_answer(k: int, simulation, state, resolve: Callable[[str], str]) -> str:
    return (
        f"advance: sample {k} went out without the controller's answer to sample {k - 1}: "
        f'{lockstep_wait(k, simulation, state, resolve)}'
    )


def not_processed(
    k: int,
    stamp: int,
    simulation,
    state,
    pending: list,
    resolve: Callable[[str], str],
    qos_problem_of: Callable,
) -> str:
    """
    Say why sample ``k`` (stamped ``stamp``) of ``simulation`` has not been processed.

    Either it did not go out (and why), or it did and ``pending`` (the watched subscriptions
    that have not processed it) name who has not.
    """
    head = (
        f'advance: sample {k} (t = {k / simulation.rate:g} s, stamp {seconds(stamp)}) '
        f'of {state.request.configuration}'
    )
    if state.simulation is not simulation or state.sent <= k:
        why = (
            lockstep_wait(k, simulation, state, resolve)
            if state.request.lockstep and simulation.command_holds and k > 0
            else 'the simulator did not publish it'
        )
        return f'{head} did not go out: {why}'
    lines = []
    for node, subscription, watch in pending:
        seen = (
            f'its callback returned for {watch.count} message(s), '
            f'the last stamped {seconds(watch.latest)}'
            if watch.count
            else 'its callback has not run for any message'
        )
        lines.append(
            f'{node_name(node)}, subscription to {subscription.topic_name} '
            f'({type_name(subscription.msg_type)}): {seen}{qos_problem_of(subscription)}'
        )
    return f'{head} was published but not processed: ' + '; '.join(lines)


def unmatched(fresh: list, qos_problem_of: Callable) -> str:
    """Say which newly watched subscriptions the simulator's publishers have not matched."""
    lines = [
        f'node {node_name(node)}, its subscription to {subscription.topic_name}'
        f'{qos_problem_of(subscription)}'
        for node, subscription, _ in fresh
        if subscription.get_publisher_count() == 0
    ]
    return (
        "discovery: the simulator's publishers have not matched every subscription to them: "
        + ('; '.join(lines) or 'each has a publisher, but a publisher lacks a subscriber')
    )


def tap_short(tap, count: int, publishers) -> str:
    """Say how many of ``count`` messages a tap got, and who publishes its topic."""
    who = (
        ', '.join(sorted({f'{p.node_namespace.rstrip("/")}/{p.node_name}' for p in publishers}))
        or 'none'
    )
    return (
        f'tap on {tap.topic} ({type_name(tap.message_type)}): '
        f'{len(tap.messages)} of {count} messages arrived; publishers on the topic: {who}'
    )
