"""The plant's settings from its parameter values (exodigit_nodes/logic/plant_settings.py).

Each value must reach the setting of its own name, whichever group holds it, and the rules that
join two parameters must refuse what they name.
"""

from dataclasses import fields

import pytest
from exodigit_nodes.logic.pacing import TimeSettings
from exodigit_nodes.logic.plant_settings import plant_settings
from exodigit_nodes.nodes.catalog import PLANT_NODE

from exodigit_model import SimulationSettings

CHANGED = {
    'clock': 'sim',
    'rate_hz': 250.0,
    'pressure_time_constant': 0.07,
    'max_supply_pressure': 150e3,
    'angle_noise_std': 2e-3,
    'pressure_noise_std': 300.0,
    'seed': 11,
    'command_timeout': 0.9,
    'effort_timeout': 0.3,
    'frame_id': 'left_glove',
    'marker_rate_hz': 4.0,
    'real_time_factor': 2.5,
    'lockstep': True,
    'lockstep_timeout': 7.0,
    'start_paused': True,
    'run_until': 3.0,
}


def changed_values():
    values = PLANT_NODE.table.defaults()
    assert all(values[name] != value for name, value in CHANGED.items())  # each one is seen
    return values | PLANT_NODE.table.check(CHANGED)


def test_each_value_reaches_the_setting_of_its_name():
    settings = plant_settings(changed_values())
    for group, kind in ((settings.simulation, SimulationSettings), (settings.time, TimeSettings)):
        for field in fields(kind):
            assert getattr(group, field.name) == CHANGED[field.name], field.name
    for name in ('command_timeout', 'effort_timeout', 'frame_id', 'marker_rate_hz'):
        assert getattr(settings, name) == CHANGED[name], name


def test_the_defaults_make_a_wall_clock_plant():
    settings = plant_settings(PLANT_NODE.table.defaults())
    assert not settings.time.lockstep and not settings.time.start_paused


@pytest.mark.parametrize('name', ['lockstep', 'start_paused'])
def test_waiting_on_the_wall_clock_is_refused_by_name(name):
    values = changed_values() | {'clock': 'wall', 'lockstep': False, 'start_paused': False}
    assert plant_settings(values).time.real_time_factor == CHANGED['real_time_factor']
    with pytest.raises(ValueError, match=f'^{name} needs clock sim'):
        plant_settings(values | {name: True})
