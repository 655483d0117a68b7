"""The ROS discovery environment and the ``--ros-args`` every glove process gets.

Discovery stays on this machine unless the user opens it (docs/networking.md, "Networking"): an
unset ``ROS_AUTOMATIC_DISCOVERY_RANGE`` becomes ``LOCALHOST``, a value set is kept, an unknown
one is refused.
"""

import math
from collections.abc import Mapping
from typing import Any

import yaml

#: Values ROS 2 Jazzy accepts for ROS_AUTOMATIC_DISCOVERY_RANGE.
DISCOVERY_RANGES = ('LOCALHOST', 'SUBNET', 'OFF', 'SYSTEM_DEFAULT')
#: Range used when the variable is unset.
DEFAULT_DISCOVERY_RANGE = 'LOCALHOST'
#: Highest domain id ROS 2 maps to valid UDP ports on Linux.
MAX_DOMAIN_ID = 232


def discovery_environment(environ: Mapping[str, str]) -> tuple[dict[str, str], str]:
    """``environ`` with its discovery settings (safe defaults filled in), and a line saying so.

    The line names the range and domain id used and where each came from.

    Raises
    ------
    ValueError
        For an unknown discovery range or a domain id that is not an integer in 0 to 232,
        naming the variable and the accepted values.
    """
    raw_range = environ.get('ROS_AUTOMATIC_DISCOVERY_RANGE', '').strip()
    discovery_range = raw_range.upper() or DEFAULT_DISCOVERY_RANGE
    if discovery_range not in DISCOVERY_RANGES:
        raise ValueError(
            f'ROS_AUTOMATIC_DISCOVERY_RANGE={raw_range!r} is not one of '
            f'{", ".join(DISCOVERY_RANGES)}'
        )
    raw_domain = environ.get('ROS_DOMAIN_ID', '').strip()
    try:
        domain_id = int(raw_domain) if raw_domain else 0
    except ValueError:
        domain_id = -1
    if not 0 <= domain_id <= MAX_DOMAIN_ID:
        raise ValueError(
            f'ROS_DOMAIN_ID={raw_domain!r} must be an integer from 0 to {MAX_DOMAIN_ID}'
        )
    env = {
        **environ,
        'ROS_AUTOMATIC_DISCOVERY_RANGE': discovery_range,
        'ROS_DOMAIN_ID': str(domain_id),
    }
    range_source, domain_source = (
        'from the environment' if raw else 'default' for raw in (raw_range, raw_domain)
    )
    return env, (
        f'ROS discovery: ROS_AUTOMATIC_DISCOVERY_RANGE={discovery_range} ({range_source}), '
        f'ROS_DOMAIN_ID={domain_id} ({domain_source})'
    )


def yaml_value(value: Any) -> str:
    """``value`` (a tuple as a list) as one line of YAML: a ``-p`` override, a parameter file's."""
    plain = list(value) if isinstance(value, tuple) else value
    # Flow style on one line; a plain scalar's document end marker ('...') follows it.
    return yaml.safe_dump(plain, default_flow_style=True, width=math.inf).splitlines()[0]


def ros_args(
    parameters: Mapping[str, Any] | None = None,
    namespace: str | None = None,
    name: str | None = None,
    extra: list[str] | None = None,
) -> list[str]:
    """The ``--ros-args`` tail: ``extra``, then overrides, namespace and node-name remaps.

    ``extra`` comes first so that the ``-p`` overrides win over a ``--params-file`` in it (the
    last setting of a parameter wins).
    """
    args = ['--ros-args', *(extra or [])]
    for key, value in (parameters or {}).items():
        args += ['-p', f'{key}:={yaml_value(value)}']
    if namespace:
        args += ['-r', f'__ns:={namespace}']
    if name:
        args += ['-r', f'__node:={name}']
    return args
