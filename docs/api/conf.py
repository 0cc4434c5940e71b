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
Sphinx configuration of the API reference: ``make docs`` builds it into ``docs/api/_build/html``.

Laid out as rosdoc2 expects a package's own Sphinx project (``conf.py``, ``index.rst`` and pages
beside it). The pages name every object by its public import path (``torquefree_ros.propagate``,
``torquefree_ros.testing.simulator``, ...) with explicit ``autofunction``/``autoclass``, never by
the internal module that defines it, so the reference does not depend on the package's internal
layout. The docstrings are plain reStructuredText (ROS's pep257 style), so no napoleon.
"""

from pathlib import Path
import re
import sys
from xml.etree import ElementTree

ROOT = Path(__file__).resolve().parents[2]
# the package from this source tree (as rosdoc2 does), installed or not
sys.path.insert(0, str(ROOT))

from torquefree_ros import PROPAGATORS  # noqa: E402 - after the path is set

_manifest = ElementTree.parse(ROOT / 'package.xml').getroot()

project = _manifest.findtext('name')
project_copyright = '2026 torquefree_ros maintainers (Apache-2.0)'
release = _manifest.findtext('version')
version = release

extensions = [
    'sphinx.ext.autodoc',
    'myst_parser',  # the contract (docs/CONTRACT.md) is Markdown, included as it is
]
source_suffix = {'.rst': 'restructuredtext', '.md': 'markdown'}
root_doc = 'index'
exclude_patterns = ['_build']

# members in the source's order; objects under their full public names (torquefree_ros.Plant), the
# types in signatures by their bare names (the modules that define them are internal)
autodoc_member_order = 'bysource'
add_module_names = True
autodoc_typehints_format = 'short'
# a method without a docstring of its own is not documented with its base class's (Gymnasium's
# VectorEnv.reset and step, whose text is about CartPole): the class's docstring covers it
autodoc_inherit_docstrings = False
# the contract's headings become link targets (contract.md#scenes)
myst_heading_anchors = 3

# the propagator names, from the registry itself
rst_epilog = '.. |propagator_names| replace:: ' + ', '.join(f'``{name}``' for name in PROPAGATORS)

html_theme = 'alabaster'
# room for the modules' names in the sidebar and for 99-column code lines
html_theme_options = {'page_width': '1160px', 'sidebar_width': '270px'}
html_title = f'{project} {release}'
html_show_sourcelink = False


def _drop_generated_docstring(app, what, name, obj, options, lines):
    """
    Drop a docstring that Python made, not this package.

    A data object's that is its type's (``dict``'s, ``str``'s) and a named tuple field's ("Alias
    for field number 0"): the entry keeps its name and type.
    """
    if what == 'data' and not isinstance(obj, type) and obj.__doc__ == type(obj).__doc__:
        lines.clear()
    elif what in ('attribute', 'property') and re.fullmatch(
        r'Alias for field number \d+', ' '.join(lines).strip()
    ):
        lines.clear()


def setup(app):
    """Connect the docstring filter."""
    app.connect('autodoc-process-docstring', _drop_generated_docstring)
