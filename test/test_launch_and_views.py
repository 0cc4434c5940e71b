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
The launch file, the RViz configuration and the Foxglove/Lichtblick layout.

Tested as far as they can be without ``launch``, ``launch_ros`` and RViz (none installable here).

* The launch file compiles; read with ``ast``, the only parameters it gives the simulator node are
  ones the node declares, its launch arguments are the documented ones, the executable is one of
  setup.py's console scripts and the files it names exist and are installed by setup.py's
  data_files.
* Run against stand-ins for ``launch``/``launch_ros`` (which record what they are given), it hands
  the node exactly the parameter file and overrides it should, and the node in process starts from
  them.
* Both views parse, and every topic and frame they name is one the node publishes under its
  defaults or with a library scene naming that output (asked of the node itself, in process); their
  frame and pose axes are thinner than the w and H arrows.
* The layout's user script is the file beside it; its output type has named numeric fields, the
  ones the plot names; compiled with TypeScript as Foxglove and Lichtblick compile it, it has no
  error and defines its output as they would, and run on the node's /diagnostics it gives the
  node's numbers.
"""

from __future__ import annotations

import ast
import json
import os
from pathlib import Path
import re
import runpy
import shutil
import subprocess
import sys
import types

from conftest import missing_requirement
import pytest
from torquefree_ros.ros.parameters import SPEC_BY_NAME
import yaml

ROOT = Path(__file__).resolve().parents[1]
LAUNCH_FILE = ROOT / 'launch' / 'torquefree.launch.py'
RVIZ_FILE = ROOT / 'rviz' / 'torquefree.rviz'
FOXGLOVE_FILE = ROOT / 'foxglove' / 'torquefree_layout.json'
PACKAGE = 'torquefree_ros'
LAUNCH_ARGUMENTS = {'scene', 'params_file', 'namespace', 'use_sim_time', 'record_bag', 'rviz'}


# -- setup.py, read by running it with setuptools.setup replaced ----------------------------------
@pytest.fixture(scope='module')
def setup_arguments():
    import setuptools

    captured = {}
    original, cwd = setuptools.setup, os.getcwd()
    setuptools.setup = lambda **arguments: captured.update(arguments)
    try:
        os.chdir(ROOT)  # its globs are relative to the project
        runpy.run_path(str(ROOT / 'setup.py'), run_name='__main__')
    finally:
        setuptools.setup, _ = original, os.chdir(cwd)
    return captured


def _installed(setup_arguments) -> dict[str, str]:
    """
    Map each source path to the directory setup.py installs it into.

    Source paths are relative to the project.
    """
    return {
        source: destination
        for destination, sources in setup_arguments['data_files']
        for source in sources
    }


def _console_scripts(setup_arguments) -> set[str]:
    return {
        entry.split('=')[0].strip() for entry in setup_arguments['entry_points']['console_scripts']
    }


def test_setup_installs_the_launch_file_and_both_views_under_share(setup_arguments):
    installed = _installed(setup_arguments)
    assert installed['launch/torquefree.launch.py'] == f'share/{PACKAGE}/launch'
    assert installed['rviz/torquefree.rviz'] == f'share/{PACKAGE}/rviz'
    assert installed['foxglove/torquefree_layout.json'] == f'share/{PACKAGE}/foxglove'
    assert installed['config/torquefree.yaml'] == f'share/{PACKAGE}/config'


# -- the launch file, read with ast ---------------------------------------------------------------
@pytest.fixture(scope='module')
def launch_tree():
    source = LAUNCH_FILE.read_text()
    compile(source, str(LAUNCH_FILE), 'exec')  # valid Python
    return ast.parse(source)


def _constants(tree) -> dict:
    """Module-level NAME = <literal or os.path.join of literals>, evaluated."""
    values = {}
    for node in tree.body:
        if (
            isinstance(node, ast.Assign)
            and len(node.targets) == 1
            and isinstance(node.targets[0], ast.Name)
        ):
            value = node.value
            if (
                isinstance(value, ast.Call)
                and ast.unparse(value.func) == 'os.path.join'
                and all(isinstance(a, ast.Constant) for a in value.args)
            ):
                values[node.targets[0].id] = os.path.join(*(a.value for a in value.args))
            else:
                try:
                    values[node.targets[0].id] = ast.literal_eval(value)
                except ValueError:
                    pass
    return values


def _keyword(call: ast.Call, name: str):
    return next((k.value for k in call.keywords if k.arg == name), None)


def _node_calls(tree):
    return [n for n in ast.walk(tree) if isinstance(n, ast.Call) and ast.unparse(n.func) == 'Node']


def _executable(call, constants) -> str:
    value = _keyword(call, 'executable')
    return value.value if isinstance(value, ast.Constant) else constants[value.id]


def test_the_launch_file_gives_the_simulator_only_parameters_it_declares(launch_tree):
    constants = _constants(launch_tree)
    calls = _node_calls(launch_tree)
    simulator = [c for c in calls if _executable(c, constants) == 'torquefree_sim']
    assert len(simulator) == 1
    # the function that builds the simulator's Node: its dict literals are the simulator's
    # parameters, except those inside the other Node calls (RViz's use_sim_time)
    (function,) = [
        f
        for f in ast.walk(launch_tree)
        if isinstance(f, ast.FunctionDef) and any(n is simulator[0] for n in ast.walk(f))
    ]
    others = {
        id(d)
        for c in calls
        if c is not simulator[0]
        for d in ast.walk(c)
        if isinstance(d, ast.Dict)
    }
    keys = {
        key.value
        for d in ast.walk(function)
        if isinstance(d, ast.Dict) and id(d) not in others
        for key in d.keys
        if isinstance(key, ast.Constant)
    }
    assert keys == {'scene', 'record_bag', 'publish_clock'}
    assert keys <= SPEC_BY_NAME.keys(), keys - SPEC_BY_NAME.keys()
    assert ast.unparse(_keyword(simulator[0], 'package')) in ('PACKAGE', repr(PACKAGE))
    assert constants['PACKAGE'] == PACKAGE


def test_the_launch_arguments_are_the_documented_ones_and_every_one_used_is_declared(launch_tree):
    constants = _constants(launch_tree)
    assert {name for name, _, _ in constants['ARGUMENTS']} == LAUNCH_ARGUMENTS
    used = {
        n.args[0].value
        for n in ast.walk(launch_tree)
        if isinstance(n, ast.Call)
        and ast.unparse(n.func) in ('value', 'LaunchConfiguration')
        and n.args
        and isinstance(n.args[0], ast.Constant)
    }
    assert used == LAUNCH_ARGUMENTS


def test_the_executable_is_a_console_script_and_the_named_files_exist_and_are_installed(
    launch_tree, setup_arguments
):
    import configparser

    constants = _constants(launch_tree)
    assert constants['EXECUTABLE'] in _console_scripts(setup_arguments)
    # launch_ros finds an executable in lib/<package>: where setup.cfg has colcon put the console
    # scripts
    setup_cfg = configparser.ConfigParser()
    setup_cfg.read(ROOT / 'setup.cfg')
    assert setup_cfg['install']['install_scripts'] == f'$base/lib/{PACKAGE}'
    installed = _installed(setup_arguments)
    for name in ('PARAMS_FILE', 'RVIZ_CONFIG'):
        relative = constants[name]  # relative to share/torquefree_ros, as to the project
        assert (ROOT / relative).is_file(), relative
        assert installed[relative] == f'share/{PACKAGE}/{os.path.dirname(relative)}', relative
    assert LAUNCH_FILE.relative_to(ROOT).as_posix() in installed


# -- the launch file, run against stand-ins for launch and launch_ros -----------------------------
class _Recorded:
    """Stand-in for a launch class: records the arguments it is given."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs


class _LaunchConfiguration:
    """Stand-in for LaunchConfiguration: ``perform`` gives the argument's value in the context."""

    def __init__(self, name):
        self.name = name

    def perform(self, context):
        return context[self.name]


def _stand_ins(monkeypatch, share: Path):
    modules = {
        name: types.ModuleType(name)
        for name in (
            'launch',
            'launch.actions',
            'launch.substitutions',
            'launch_ros',
            'launch_ros.actions',
        )
    }
    modules['launch'].LaunchDescription = _Recorded
    modules['launch.actions'].DeclareLaunchArgument = type(
        'DeclareLaunchArgument', (_Recorded,), {}
    )
    modules['launch.actions'].OpaqueFunction = type('OpaqueFunction', (_Recorded,), {})
    modules['launch.substitutions'].LaunchConfiguration = _LaunchConfiguration
    modules['launch_ros.actions'].Node = type('Node', (_Recorded,), {})
    for name, module in modules.items():
        monkeypatch.setitem(sys.modules, name, module)
    import ament_index_python.packages as packages

    monkeypatch.setattr(
        packages,
        'get_package_share_directory',
        lambda package: str(share) if package == PACKAGE else pytest.fail(package),
    )


def _launch(monkeypatch, share: Path, **given):
    """
    Return the actions the launch file starts for launch arguments ``given``.

    The launch arguments not given take their defaults.
    """
    _stand_ins(monkeypatch, share)
    module = runpy.run_path(str(LAUNCH_FILE))
    description = module['generate_launch_description']()
    (declared_and_function,) = description.args
    arguments = {a.args[0]: a.kwargs['default_value'] for a in declared_and_function[:-1]}
    assert set(arguments) == LAUNCH_ARGUMENTS
    unknown = set(given) - set(arguments)
    assert not unknown, unknown
    return declared_and_function[-1].kwargs['function']({**arguments, **given})


@pytest.fixture
def share(tmp_path):
    """Build an installed share/torquefree_ros, as setup.py's data_files lay it out."""
    share = tmp_path / 'share' / PACKAGE
    for relative in ('config/torquefree.yaml', 'rviz/torquefree.rviz'):
        (share / relative).parent.mkdir(parents=True, exist_ok=True)
        (share / relative).write_bytes((ROOT / relative).read_bytes())
    return share


def test_by_default_the_launch_starts_the_node_on_the_shipped_parameter_file_alone(
    monkeypatch, share
):
    (node,) = _launch(monkeypatch, share)
    assert node.kwargs['package'] == PACKAGE and node.kwargs['executable'] == 'torquefree_sim'
    assert node.kwargs['name'] == 'torquefree' and node.kwargs['namespace'] == ''
    # nothing overrides the file: an empty scene would replace the file's scene by the default one
    assert node.kwargs['parameters'] == [str(share / 'config' / 'torquefree.yaml')]


def test_given_arguments_override_the_parameter_file_and_rviz_opens_on_the_shipped_view(
    monkeypatch, share, tmp_path
):
    own = tmp_path / 'own.yaml'
    own.write_text('/**:\n  ros__parameters:\n    publish_rate: 50.0\n')
    node, rviz = _launch(
        monkeypatch,
        share,
        scene='dzhanibekov',
        params_file=str(own),
        namespace='/sat1/',
        record_bag=str(tmp_path / 'bag'),
        rviz='true',
        use_sim_time='true',
    )
    assert node.kwargs['namespace'] == 'sat1'
    # use_sim_time: the simulator publishes /clock whatever real_time_factor the file sets
    assert node.kwargs['parameters'] == [
        str(own),
        {'scene': 'dzhanibekov'},
        {'record_bag': str(tmp_path / 'bag')},
        {'publish_clock': True},
    ]
    assert rviz.kwargs['executable'] == 'rviz2'
    assert rviz.kwargs['arguments'] == ['-d', str(share / 'rviz' / 'torquefree.rviz')]
    assert rviz.kwargs['parameters'] == [{'use_sim_time': True}]
    # the view's absolute topics follow the node into its namespace
    assert rviz.kwargs['remappings'] == [('/markers', '/sat1/markers'), ('/pose', '/sat1/pose')]


def test_use_sim_time_false_leaves_publish_clock_to_the_parameter_file(monkeypatch, share):
    (node,) = _launch(monkeypatch, share, use_sim_time='false')
    assert node.kwargs['parameters'] == [str(share / 'config' / 'torquefree.yaml')]
    with pytest.raises(ValueError, match=r"use_sim_time: expected true or false, got 'on'"):
        _launch(monkeypatch, share, use_sim_time='on')


def test_a_launch_flag_that_is_not_true_or_false_is_refused_with_its_name(monkeypatch, share):
    with pytest.raises(ValueError, match=r"rviz: expected true or false, got 'yes'"):
        _launch(monkeypatch, share, rviz='yes')


def test_the_node_starts_from_what_the_launch_gives_it(monkeypatch, share, tmp_path):
    """
    The node starts from what the launch file gives it.

    What ``ros2 launch`` would pass (--params-file, then -p overrides), given to the node in
    process.
    """
    from sim_harness import connected_harness

    bag = tmp_path / 'recorded'
    (node,) = _launch(
        monkeypatch, share, scene='dzhanibekov', record_bag=str(bag), use_sim_time='true'
    )
    params_file, *overrides = node.kwargs['parameters']
    arguments = ['--ros-args', '--params-file', params_file]
    for override in overrides:
        ((name, value),) = override.items()
        arguments += ['-p', f'{name}:={str(value).lower() if isinstance(value, bool) else value}']
    with connected_harness(args=arguments) as harness:
        assert harness.get_parameter('scene') == 'dzhanibekov'
        assert harness.get_parameter('record_bag') == str(bag)
        assert harness.get_parameter('publish_clock') is True
        # the shipped file's: /clock all the same
        assert harness.get_parameter('real_time_factor') == 1.0
        harness.wait_samples(5)
        stamps = set(harness.omega)
        harness.spin_until(
            lambda: any(c in stamps for c in harness.clock), what="/clock at the samples' stamps"
        )
    assert (bag / 'metadata.yaml').is_file()


# -- the views ------------------------------------------------------------------------------------
@pytest.fixture(scope='module')
def published():
    """
    Return the topics the node publishes and the frames it names by default.

    Topics relative to its namespace (absolute ones as they are), under its defaults and with every
    library scene naming an output.
    """
    from sim_harness import connected_harness
    from torquefree_ros import load_scene
    from torquefree_ros.core.scene.library import library_scenes

    topics = set()
    with connected_harness(publish_rate=50.0) as harness:
        node = harness.node
        prefix = node.get_namespace().rstrip('/') + '/'

        def current():
            names = node.get_publisher_names_and_types_by_node(
                node.get_name(), node.get_namespace()
            )
            return {
                '/' + name[len(prefix):] if name.startswith(prefix) else name for name, _ in names
            }

        topics |= current()
        for scene in sorted(library_scenes()):
            if load_scene(scene).outputs:
                assert harness.set_parameters(scene=scene)[0].successful, scene
                response = harness.reset()
                assert response.success, response.message
                topics |= current()
    frames = {SPEC_BY_NAME['inertial_frame'].default, SPEC_BY_NAME['body_frame'].default}
    return topics, frames


def _walk(value, path=()):
    """(path, key, value) of every mapping entry, depth first."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield path, key, item
            yield from _walk(item, path + (key,))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _walk(item, path + (index,))


def test_the_rviz_view_names_only_what_the_node_publishes(published):
    topics, frames = published
    config = yaml.safe_load(RVIZ_FILE.read_text())
    manager = config['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == 'world'
    displays = {d['Class'].rsplit('/', 1)[-1]: d for d in manager['Displays']}
    assert {'TF', 'MarkerArray', 'Pose', 'Axes'} <= displays.keys()
    assert displays['MarkerArray']['Topic']['Value'] == '/markers'
    assert displays['Pose']['Topic']['Value'] == '/pose'
    assert displays['Axes']['Reference Frame'] == 'body'
    assert all(d['Enabled'] for d in displays.values())
    named_topics = {item['Value'] for _, key, item in _walk(config) if key == 'Topic'}
    named_frames = {
        item
        for _, key, item in _walk(config)
        if key in ('Fixed Frame', 'Reference Frame', 'Target Frame') and item != '<Fixed Frame>'
    }
    assert named_topics and named_topics <= topics, named_topics - topics
    assert named_frames == frames
    # reliable, as the node offers (a best-effort request would match too, a stricter one would
    # not)
    policies = {
        display['Topic']['Reliability Policy']
        for display in displays.values()
        if 'Topic' in display
    }
    assert policies == {'Reliable'}


def test_the_foxglove_layout_names_only_what_the_node_publishes(published):
    topics, frames = published
    layout = json.loads(FOXGLOVE_FILE.read_text())
    panels = layout['configById']
    three_d = next(config for name, config in panels.items() if name.startswith('3D!'))
    assert three_d['followTf'] == 'world'
    assert three_d['topics']['/markers']['visible'] is True
    # the 1 m body fills the view, not a speck at 20 m
    assert three_d['cameraState']['distance'] <= 5.0
    plots = [config for name, config in panels.items() if name.startswith('Plot!')]
    plotted = [path['value'] for plot in plots for path in plot['paths']]
    script_output = '/studio_script/torquefree_invariants'
    assert plotted == [
        '/angular_velocity.vector.x',
        '/angular_velocity.vector.y',
        '/angular_velocity.vector.z',
        f'{script_output}.kinetic_energy',
        f'{script_output}.angular_momentum',
    ]
    # the user script's output is what it declares, computed from a topic the node publishes
    (script,) = layout['userNodes'].values()
    assert f'export const output = "{script_output}";' in script['sourceCode']
    assert (
        'export const inputs = ["/diagnostics"];' in script['sourceCode']
        and '/diagnostics' in topics
    )
    plotted = [path for path in plotted if not path.startswith(script_output)]
    raw = [
        config['topicPath'] for name, config in panels.items() if name.startswith('RawMessages!')
    ]
    assert raw

    # every panel in the layout tree is configured, every configured panel is in the tree
    def leaves(node):
        return [node] if isinstance(node, str) else leaves(node['first']) + leaves(node['second'])

    assert sorted(leaves(layout['layout'])) == sorted(panels)

    named_topics = set(three_d['topics']) | {path.split('.', 1)[0] for path in plotted + raw}
    named_frames = (
        {three_d['followTf']}
        | {key.split(':', 1)[1] for key in three_d['transforms']}
        | {layer['frameId'] for layer in three_d['layers'].values() if 'frameId' in layer}
    )
    assert named_topics <= topics, named_topics - topics
    assert named_frames == frames


# Foxglove's and Lichtblick's 3-D panel draws an axis (a frame's, a pose's) 0.2 m long with a shaft
# 0.02 m across (their Axis), scaled: a frame's by the scene's transforms axisScale, a pose's to
# axisScale m long
PANEL_AXIS_LENGTH, PANEL_AXIS_SHAFT = 0.2, 0.02
MARKER_SIZE = 1.0  # m: the markers output's default box, every library scene's


def test_the_views_draw_axes_thinner_than_the_w_and_h_arrows():
    """
    The views draw frame and pose axes thinner than the w and H arrows.

    An arrow along a body axis (a spin about a principal axis) inside a thicker axis is hidden.
    """
    from torquefree_ros.bag.markers import ANGULAR_MOMENTUM, ANGULAR_VELOCITY

    thinnest = MARKER_SIZE * min(ANGULAR_VELOCITY.size[0], ANGULAR_MOMENTUM.size[0])
    panels = json.loads(FOXGLOVE_FILE.read_text())['configById']
    three_d = next(config for name, config in panels.items() if name.startswith('3D!'))
    pose_scale = three_d['topics']['/pose']['axisScale']
    displays = {
        d['Class'].rsplit('/', 1)[-1]: d
        for d in yaml.safe_load(RVIZ_FILE.read_text())['Visualization Manager']['Displays']
    }
    shafts = {
        'Foxglove /pose': pose_scale * PANEL_AXIS_SHAFT / PANEL_AXIS_LENGTH,
        'Foxglove frames': three_d['scene']['transforms']['axisScale'] * PANEL_AXIS_SHAFT,
        'RViz Pose': 2 * displays['Pose']['Axes Radius'],
        'RViz Axes': 2 * displays['Axes']['Radius'],
    }
    thick = {view: shaft for view, shaft in shafts.items() if not shaft < thinnest}
    assert not thick, f'axes as thick as the arrows ({thinnest} m) hide them: {thick}'


INVARIANTS_SCRIPT = ROOT / 'foxglove' / 'torquefree_invariants.ts'
SCRIPT_OUTPUT = '/studio_script/torquefree_invariants'
INVARIANTS = [
    'kinetic_energy',
    'angular_momentum',
    'kinetic_energy_drift',
    'angular_momentum_drift',
]
# what the script's type declared before it had named fields: the apps rejected the script
INDEX_SIGNATURE = 'type Invariants = { [key: string]: number };'


def test_the_layout_embeds_the_invariants_script_file():
    layout = json.loads(FOXGLOVE_FILE.read_text())
    assert (
        layout['userNodes']['torquefree_invariants']['sourceCode'] == INVARIANTS_SCRIPT.read_text()
    )


def _output_fields(source: str) -> dict[str, str]:
    """
    Return the fields of the type a user script's default export returns: name -> type.

    A structural reading of what the apps' type extraction needs: the return type (without
    ``| undefined``) is a type alias of a type literal, each member ``name: type``. Anything else
    raises AssertionError; an index signature with the apps' own words.
    """
    returned = re.search(
        r'^export default function \w*\([^)]*\): (\w+)(?: \| undefined)? \{$', source, re.M
    )
    assert returned, 'the default export must be a function returning a named type'
    literal = re.search(rf'^type {returned[1]} = \{{(.*?)\}};?$', source, re.M | re.S)
    assert literal, f'{returned[1]}: must be a type alias of a type literal'
    body = re.sub(r'//[^\n]*', '', literal[1])
    fields = {}
    for member in filter(None, (m.strip() for m in re.split(r'[;,\n]', body))):
        assert not member.startswith('['), f'Encountered type member with no name: {member}'
        named = re.fullmatch(r'([A-Za-z_]\w*)\s*:\s*(\w+)', member)
        assert named, f'{member}: not a named field of a plain type'
        fields[named[1]] = named[2]
    return fields


def test_the_invariants_script_returns_named_numbers_and_the_plot_names_them():
    """
    The invariants script returns named numbers, and the plot names them.

    Lichtblick and Foxglove make the output's message definition from the type the script's
    default export returns; an index signature (``{ [key: string]: number }``) is refused
    ("Encountered type member with no name") and the plot stays empty.
    """
    source = INVARIANTS_SCRIPT.read_text()
    assert _output_fields(source) == dict.fromkeys(INVARIANTS, 'number')
    with pytest.raises(AssertionError, match='Encountered type member with no name'):
        _output_fields(_with_index_signature(source))
    layout = json.loads(FOXGLOVE_FILE.read_text())
    plotted = [
        path['value']
        for name, config in layout['configById'].items()
        if name.startswith('Plot!')
        for path in config['paths']
        if path['value'].startswith(SCRIPT_OUTPUT + '.')
    ]
    assert plotted and {p[len(SCRIPT_OUTPUT) + 1:] for p in plotted} <= set(INVARIANTS)


def _with_index_signature(source: str) -> str:
    """Return the script with its output type replaced by the index signature the apps refuse."""
    declared = re.search(r'^type Invariants = \{.*?^\};$', source, re.M | re.S)
    return source.replace(declared[0], INDEX_SIGNATURE)


def _typescript() -> tuple[str, Path]:
    """
    Return node.js and the TypeScript compiler ``make test`` installs beside the virtualenv.

    Without them the test is skipped, except on CI, where it fails.
    """
    typescript = Path(sys.prefix) / 'npm' / 'node_modules' / 'typescript'
    node = shutil.which('node')
    if node is None or not (typescript / 'package.json').is_file():
        missing_requirement(f'node.js and TypeScript in {typescript} check the user script')
    return node, typescript


def _check_user_script(script: Path, event: dict | None = None, tmp_path: Path | None = None):
    """
    Check a user script as the apps do (test/check_user_script.js) and run it on ``event``.

    Returns what the check prints: the compiler's diagnostics, the type extraction's problems, the
    output topic, the inputs, the output's fields and the script's result.
    """
    node, typescript = _typescript()
    arguments = [node, str(ROOT / 'test' / 'check_user_script.js'), str(typescript), str(script)]
    if event is not None:
        (tmp_path / 'event.json').write_text(json.dumps(event))
        arguments.append(str(tmp_path / 'event.json'))
    result = subprocess.run(arguments, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def test_the_invariants_script_compiles_and_defines_its_output_as_the_apps_do(tmp_path):
    checked = _check_user_script(INVARIANTS_SCRIPT)
    assert checked['diagnostics'] == [] and checked['problems'] == []
    assert checked['output'] == SCRIPT_OUTPUT and checked['inputs'] == ['/diagnostics']
    assert checked['fields'] == [[name, 'float64'] for name in INVARIANTS]
    # the check finds what the apps found in the script with an index signature
    refused = tmp_path / 'index_signature.ts'
    refused.write_text(_with_index_signature(INVARIANTS_SCRIPT.read_text()))
    checked = _check_user_script(refused)
    assert checked['problems'] == ['Encountered type member with no name']


def test_the_invariants_script_turns_the_nodes_diagnostics_into_numbers(tmp_path):
    """
    The invariants script turns the node's diagnostics into numbers.

    The user script, compiled by TypeScript as the apps compile it and run in node.js on a
    /diagnostics message the node published, gives the very numbers the node wrote as text.
    """
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import QoSProfile
    from sim_harness import connected_harness

    _typescript()
    arrays = []
    with connected_harness(publish_rate=50.0) as harness:
        harness.client.create_subscription(
            DiagnosticArray, '/diagnostics', arrays.append, QoSProfile(depth=10)
        )

        def values():
            return {
                pair.key: pair.value
                for array in arrays
                for status in array.status
                for pair in status.values
            }

        harness.spin_until(
            lambda: 'kinetic_energy' in values(), timeout=30.0, what="the node's invariants"
        )
    array = next(
        a for a in arrays if any(p.key == 'kinetic_energy' for s in a.status for p in s.values)
    )
    event = {
        'message': {
            'status': [
                {'name': s.name, 'values': [{'key': p.key, 'value': p.value} for p in s.values]}
                for s in array.status
            ]
        }
    }
    numbers = _check_user_script(INVARIANTS_SCRIPT, event, tmp_path)['result']
    text = {p.key: p.value for s in array.status for p in s.values}
    assert numbers == {key: float(text[key]) for key in INVARIANTS}
    assert numbers['kinetic_energy'] > 0.0
