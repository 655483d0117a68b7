"""The ROS parameter files ``config/<executable>.yaml``, generated from the node table.

Each file sets every parameter of one node to its default, after a comment with its meaning, SI
unit and rule (:data:`.catalog.EXECUTABLES`); a test checks the committed files against this::

    python -m exodigit_nodes.nodes.config_files --write-config exodigit_nodes/config
"""

from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

from ..logic.ros_env import yaml_value
from .catalog import EXECUTABLES
from .node_entry import NodeEntry

CONFIG_WIDTH = 99
"""Longest line of a generated parameter file's comments, characters."""


def config_text(entry: NodeEntry) -> str:
    """A node's ROS parameter file (``/**: ros__parameters:``), every parameter at its default."""
    path = f'config/{entry.config_file}'
    lines = [
        *comment(
            f'ROS 2 parameters of the {entry.executable} node ({entry.summary}), each at its '
            'default; SI units, joint vectors [MCP, PIP, DIP]. Use: ros2 run exodigit_nodes '
            f'{entry.executable} --ros-args --params-file {path} (or python -m {entry.module} '
            '...).'
        ),
        '# Generated from exodigit_nodes/nodes/catalog.py: edit the table there, then run',
        '#   python -m exodigit_nodes.nodes.config_files --write-config exodigit_nodes/config',
        '/**:',
        '  ros__parameters:',
    ]
    for spec in entry.table.specs.values():
        lines += comment(' '.join(filter(None, (spec.description, spec.rule()))), '    ', '  ')
        lines.append(f'    {spec.name}: {yaml_value(spec.default)}')
    return '\n'.join(lines) + '\n'


def comment(text: str, indent: str = '', hang: str = '') -> list[str]:
    """``text`` as YAML comment lines of at most ``CONFIG_WIDTH`` characters.

    Each line starts with ``indent``; lines after the first are indented by ``hang`` more.
    """
    return textwrap.wrap(
        text,
        CONFIG_WIDTH,
        initial_indent=f'{indent}# ',
        subsequent_indent=f'{indent}# {hang}',
        break_on_hyphens=False,
    )


def main(argv: list[str] | None = None) -> int:
    """``python -m exodigit_nodes.nodes.config_files --write-config DIR``: write the files."""
    parser = argparse.ArgumentParser(
        prog='python -m exodigit_nodes.nodes.config_files',
        description="Write each glove node's ROS parameter file (<executable>.yaml, every "
        'parameter at its default) from the node table.',
    )
    parser.add_argument(
        '--write-config',
        type=Path,
        required=True,
        metavar='DIR',
        help='directory to write into (the package: exodigit_nodes/config)',
    )
    args = parser.parse_args(argv)
    if not args.write_config.is_dir():
        parser.error(f'--write-config {args.write_config}: no such directory')
    for entry in EXECUTABLES:
        path = args.write_config / entry.config_file
        path.write_text(config_text(entry))
        print(f'wrote {path}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
