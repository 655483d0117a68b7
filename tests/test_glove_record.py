"""The glove's ROS-free parts: joining plant steps, the run record, the summary, discovery env."""

import io
import math
from datetime import datetime

import numpy as np
import pytest
from exodigit_nodes.logic.ros_env import discovery_environment
from exodigit_nodes.runner.run_record import RunRecord, csv_columns, new_run_directory, read_csv
from exodigit_nodes.runner.summary import (
    JOINT_LABELS,
    SIGNALS,
    GloveSignals,
    SummaryDisplay,
    net_openings,
)
from png_files import png_size

NODES = ('plant', 'estimator', 'pressure_command')


PERIOD = 0.01  # s, plant step in these tests
PLANT_ORDER = ('chamber_pressure', 'joint_states', 'contact_forces')


def step_messages(step, p, delays=(0.0, 50e-6, 100e-6)):
    """The plant's three messages of one step: (topic, values, published, stamp).

    Chamber ``p`` Pa, angles ``p / 1e5`` rad, forces ``p / 1e4`` N, so a joined sample shows
    whether its values come from one step; published in the plant's order, ``delays`` after
    the start of the step.
    """
    start = 1000.0 + PERIOD * step
    values = {'chamber_pressure': p, 'joint_states': p / 1e5, 'contact_forces': p / 1e4}
    return [
        (topic, np.full(3, values[topic]), start + delay, 100.0 + PERIOD * step)
        for topic, delay in zip(PLANT_ORDER, delays, strict=True)
    ]


def feed(signals, messages):
    """Deliver messages in the given order; all samples they complete."""
    samples = []
    for topic, values, published, stamp in messages:
        stamp = stamp if topic == 'joint_states' else None
        samples += signals.update(topic, values, published, stamp)
    return samples


def run_steps(signals, pressures):
    """Deliver whole steps in publication order (and the next one, which closes the last)."""
    messages = [m for i, p in enumerate([*pressures, -1.0]) for m in step_messages(i, p)]
    samples = feed(signals, messages)
    assert len(samples) == len(pressures)
    return samples


def assert_one_step(sample, p=None):
    chamber = sample.values['chamber_pressure']
    np.testing.assert_array_equal(sample.values['joint_states'], chamber / 1e5)
    np.testing.assert_array_equal(sample.values['contact_forces'], chamber / 1e4)
    if p is not None:
        np.testing.assert_array_equal(chamber, np.full(3, p))


@pytest.mark.parametrize('order', [(0, 1, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)])
def test_a_sample_joins_the_three_topics_of_one_plant_step_in_any_delivery_order(order):
    signals = GloveSignals(NODES)
    signals.update('pressure_command', [1.0, 2.0, 3.0])
    pressures = [1000.0, 2000.0, 3000.0]
    messages = []
    for step, p in enumerate([*pressures, 0.0]):
        in_step = step_messages(step, p)
        messages += [in_step[i] for i in order]
    samples = feed(signals, messages)
    assert [s.time for s in samples] == pytest.approx([0.0, PERIOD, 2 * PERIOD])
    for sample, p in zip(samples, pressures, strict=True):
        assert_one_step(sample, p)
        np.testing.assert_array_equal(sample.values['pressure_command'], [1.0, 2.0, 3.0])
        assert sample.values['estimated_contact_forces'] is None


def estimate(signals, step):
    """The estimator's estimate of ``step`` (forces 0.1 · (step + 1) N); what it hands on."""
    return signals.update(
        'estimated_contact_forces', np.full(3, 0.1 * (step + 1)), stamp=100.0 + PERIOD * step
    )


def test_an_estimate_joins_the_step_its_stamp_names_however_late_it_comes():
    # The estimator answers from another process. A joined step waits for its estimate until it
    # comes (step 1's, after step 2's pressure) or a later step's does (step 2's never comes:
    # step 3's tells), and never takes another step's.
    signals = GloveSignals(NODES)
    assert estimate(signals, 0) == []  # before its step is joined
    samples = feed(signals, step_messages(0, 1000.0) + step_messages(1, 2000.0))
    assert feed(signals, step_messages(2, 3000.0)[:1]) == []  # step 1 joined, waits
    samples += estimate(signals, 1)
    samples += feed(signals, step_messages(2, 3000.0)[1:] + step_messages(3, 4000.0))
    assert len(samples) == 2  # step 2 waits for an estimate
    samples += estimate(signals, 3)  # the estimator left step 2 out
    samples += feed(signals, step_messages(4, 0.0)[:1])
    assert [s.time for s in samples] == pytest.approx([0.0, PERIOD, 2 * PERIOD, 3 * PERIOD])
    found = [s.values['estimated_contact_forces'] for s in samples]
    np.testing.assert_array_equal(found[0], [0.1] * 3)
    np.testing.assert_array_equal(found[1], [0.2] * 3)
    assert found[2] is None
    np.testing.assert_array_equal(found[3], [0.4] * 3)


def test_with_an_estimator_the_first_steps_wait_for_its_first_estimate():
    # Its first estimate is of step 1 (it started late): step 0 goes without one.
    signals = GloveSignals(NODES, estimated=True)
    assert feed(signals, step_messages(0, 1000.0) + step_messages(1, 2000.0)[:1]) == []
    assert feed(signals, step_messages(1, 2000.0)[1:] + step_messages(2, 3000.0)[:1]) == []
    samples = estimate(signals, 1)
    assert [s.time for s in samples] == pytest.approx([0.0, PERIOD])
    assert samples[0].values['estimated_contact_forces'] is None
    np.testing.assert_array_equal(samples[1].values['estimated_contact_forces'], [0.2] * 3)


def test_without_an_estimator_no_step_waits():
    signals = GloveSignals(NODES)
    samples = feed(signals, step_messages(0, 1000.0) + step_messages(1, 2000.0)[:1])
    assert len(samples) == 1 and samples[0].values['estimated_contact_forces'] is None


def test_steps_delivered_topic_by_topic_are_not_mixed():
    # Each topic keeps its own order (DDS), but one topic may run several steps ahead.
    signals = GloveSignals(NODES)
    steps = [step_messages(i, 1000.0 * (i + 1)) for i in range(4)]
    by_topic = [steps[i][k] for k in (1, 2, 0) for i in range(4)]
    samples = feed(signals, by_topic)
    assert [s.values['chamber_pressure'][0] for s in samples] == [1000.0, 2000.0, 3000.0]
    for sample in samples:
        assert_one_step(sample)


def test_a_late_message_joins_its_own_step_not_the_next_one():
    # The plant is preempted before publishing the forces of step 0; step 1 follows at once.
    signals = GloveSignals(NODES)
    late = step_messages(0, 1000.0, delays=(0.0, 50e-6, 9.5e-3))
    early = step_messages(1, 2000.0, delays=(-0.4e-3, -0.35e-3, -0.3e-3))
    samples = feed(signals, late + early + step_messages(2, 3000.0))
    assert [s.values['chamber_pressure'][0] for s in samples] == [1000.0, 2000.0]
    for sample in samples:
        assert_one_step(sample)


def test_a_step_the_plant_stalled_in_keeps_its_messages():
    # The plant stopped for 0.3 s (a garbage collection, a busy machine) after a step's pressure:
    # its angles and forces, and every later step, come 0.3 s late, and still join (one make test
    # run, seed 2402432981, lost such a step from a lockstep record while its bag had it).
    signals = GloveSignals(NODES)
    stall = (0.0, 0.3, 0.3 + 50e-6)
    later = (0.3 + 100e-6, 0.3 + 150e-6, 0.3 + 200e-6)
    messages = step_messages(0, 1000.0) + step_messages(1, 2000.0, stall)
    messages += step_messages(2, 3000.0, later) + step_messages(3, 4000.0, later)
    samples = feed(signals, messages) + signals.flush()
    assert [s.values['chamber_pressure'][0] for s in samples] == [1000.0, 2000.0, 3000.0, 4000.0]
    for sample in samples:
        assert_one_step(sample)
    assert signals.unjoined == 0


def test_a_step_with_a_lost_message_is_skipped_and_the_others_join():
    signals = GloveSignals(NODES)
    messages = [m for i in range(5) for m in step_messages(i, 1000.0 * (i + 1))]
    lost = [messages[5], messages[7]]  # forces of step 1, angles of step 2
    samples = feed(signals, [m for m in messages if not any(m is x for x in lost)])
    assert [s.values['chamber_pressure'][0] for s in samples] == [1000.0, 4000.0]
    for sample in samples:
        assert_one_step(sample)
    # what the runner reports: the other two messages of each of the two broken steps
    assert [s.values['chamber_pressure'][0] for s in signals.flush()] == [5000.0]
    assert signals.unjoined == 4


def test_a_summary_started_between_two_publications_of_a_step_joins_from_the_next_step():
    # It missed step 0's pressure and heard its angles and forces first.
    signals = GloveSignals(NODES)
    messages = [m for i in range(4) for m in step_messages(i, 1000.0 * (i + 1))][1:]
    samples = feed(signals, messages) + signals.flush()
    assert [s.values['chamber_pressure'][0] for s in samples] == [2000.0, 3000.0, 4000.0]
    for sample in samples:
        assert_one_step(sample)
    assert [s.time for s in samples] == pytest.approx([0.0, PERIOD, 2 * PERIOD])


def test_unknown_signals_are_refused():
    with pytest.raises(ValueError, match='unknown signal'):
        GloveSignals(NODES).update('cmd_vel', [0.0, 0.0, 0.0])


def test_run_record_csv_holds_display_units_and_empty_cells_for_missing_values(tmp_path):
    record = RunRecord(tmp_path / 'run')
    signals = GloveSignals(NODES)
    pressures = [12_345.0, 50_000.0]
    samples = feed(signals, step_messages(0, pressures[0]) + step_messages(1, pressures[1]))
    signals.update('estimated_contact_forces', [0.5, 0.25, 0.125], stamp=100.0 + PERIOD)
    samples += feed(signals, step_messages(2, 0.0))
    for sample in samples:
        record.write(sample)
    record.close()
    table = read_csv(record.csv_path)
    assert list(table) == csv_columns()
    np.testing.assert_allclose(table['time_s'], [0.0, PERIOD])
    np.testing.assert_allclose(table['p_mcp_kpa'], np.array(pressures) / 1000.0, rtol=1e-12)
    np.testing.assert_allclose(
        table['q_dip_deg'], np.degrees(np.array(pressures) / 1e5), rtol=1e-11
    )
    np.testing.assert_allclose(table['f_pip_n'], np.array(pressures) / 1e4, rtol=1e-12)
    assert math.isnan(table['f_est_mcp_n'][0]) and table['f_est_dip_n'][1] == 0.125
    assert np.isnan(table['p_cmd_mcp_kpa']).all()
    assert record.rows == 2


def test_run_record_plot_is_a_png_of_sensible_size(tmp_path):
    record = RunRecord(tmp_path)
    signals = GloveSignals(NODES)
    signals.update('pressure_command', np.full(3, 10e3))
    for sample in run_steps(signals, 1e3 * np.arange(50)):
        record.write(sample)
    record.close()
    assert record.plot() == record.plot_path
    width, height = png_size(record.plot_path)
    assert 600 <= width <= 2000 and 600 <= height <= 2000
    assert record.plot_path.stat().st_size > 20_000  # four panels of curves, not a blank image


def test_an_empty_run_has_no_plot(tmp_path):
    record = RunRecord(tmp_path)
    record.close()
    assert record.plot() is None
    assert not record.plot_path.exists()


def test_run_directories_are_never_reused(tmp_path):
    now = datetime(2026, 1, 2, 3, 4, 5)
    first, second = new_run_directory(tmp_path, now), new_run_directory(tmp_path, now)
    assert first.name == '20260102-030405' and second.name == '20260102-030405-1'
    assert first.is_dir() and second.is_dir()


def test_summary_table_and_line_show_values_in_display_units():
    signals = GloveSignals(NODES)
    feed(signals, step_messages(0, 25_000.0))
    signals.update_health('plant', 0, 'ok', now=10.0)
    signals.update_health('estimator', 1, 'stale sample', now=10.0)
    table = signals.table(now=11.0, title='glove')
    angle = f'{math.degrees(0.25):.2f}'
    assert angle in table and '25.00' in table and 'kPa' in table and 'deg' in table
    line = signals.line(now=11.0)
    assert f'q_deg=[{angle} {angle} {angle}]' in line
    assert 'plant OK' in line and 'estimator WARN (stale sample)' in line
    assert 'pressure_command (no diagnostics yet)' in line
    assert 'plant SILENT' in signals.line(now=20.0)
    for signal in SIGNALS.values():
        assert signal.label in table


def test_the_table_s_values_line_up_under_their_joints_whatever_the_row_label():
    signals = GloveSignals(NODES, {'estimated_rest_angle': {'patient': [0.4, 0.6, 0.4]}})
    signals.update('estimated_rest_angle', [0.2, 0.3, 0.1])
    lines = signals.table(now=0.0, title='glove').splitlines()
    ends = [lines[1].index(joint) + len(joint) for joint in JOINT_LABELS]
    rows = [line for line in lines if line.startswith(('rest est ', 'rest patient '))]
    assert len(rows) == 2, lines
    for row in rows:  # each value's last digit under its joint label's last letter
        assert [row[end - 1] != ' ' and row[end] == ' ' for end in ends] == [True] * 3, lines


def test_display_prints_one_line_per_period_without_a_terminal_and_redraws_on_one():
    signals = GloveSignals(NODES)
    plain = io.StringIO()
    display = SummaryDisplay(plain, interactive=False, line_period=1.0)
    for now in np.arange(0.0, 3.0, 0.25):
        display.show([(signals, 'glove')], now)
    assert len(plain.getvalue().splitlines()) == 3
    assert '\x1b' not in plain.getvalue()
    tty = io.StringIO()
    display = SummaryDisplay(tty, interactive=True)
    display.show([(signals, 'glove')], 0.0)
    lines = len(tty.getvalue().splitlines())
    display.show([(signals, 'glove')], 0.25)
    assert f'\x1b[{lines}F\x1b[J' in tty.getvalue()


def test_discovery_defaults_to_localhost_and_keeps_what_the_user_set():
    env, line = discovery_environment({'PATH': '/bin'})
    assert env == {
        'PATH': '/bin',
        'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
        'ROS_DOMAIN_ID': '0',
    }
    assert 'LOCALHOST (default)' in line and 'ROS_DOMAIN_ID=0 (default)' in line
    env, line = discovery_environment(
        {'ROS_AUTOMATIC_DISCOVERY_RANGE': 'subnet', 'ROS_DOMAIN_ID': '42'}
    )
    assert (env['ROS_AUTOMATIC_DISCOVERY_RANGE'], env['ROS_DOMAIN_ID']) == ('SUBNET', '42')
    assert 'SUBNET (from the environment)' in line and '=42 (from the environment)' in line


@pytest.mark.parametrize(
    ('environ', 'message'),
    [
        ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LAN'}, 'ROS_AUTOMATIC_DISCOVERY_RANGE'),
        ({'ROS_DOMAIN_ID': 'abc'}, 'ROS_DOMAIN_ID'),
        ({'ROS_DOMAIN_ID': '233'}, 'ROS_DOMAIN_ID'),
        ({'ROS_DOMAIN_ID': '-1'}, 'ROS_DOMAIN_ID'),
    ],
)
def test_discovery_refuses_unknown_values(environ, message):
    with pytest.raises(ValueError, match=message):
        discovery_environment(environ)


def test_flush_joins_the_last_step_once_nothing_more_will_come():
    signals = GloveSignals(NODES)
    messages = [m for i in range(3) for m in step_messages(i, 1000.0 * (i + 1))]
    assert len(feed(signals, messages)) == 2  # the last step waits for a later message
    assert signals.received_stamp == pytest.approx(100.0 + 2 * PERIOD)
    last = signals.flush()
    assert [s.values['chamber_pressure'][0] for s in last] == [3000.0]
    assert_one_step(last[0])
    assert signals.flush() == []


def test_a_valve_command_shows_as_each_joint_s_net_opening_in_percent():
    # With actuation valves the summary's 'valves' row is u_in − u_out per joint: + fills,
    # − vents, 0 holds (fails if the inlets and outlets were paired otherwise).
    net = net_openings([0.4, 0.0, 0.0, 0.0, 0.25, 0.0])
    np.testing.assert_array_equal(net, [0.4, -0.25, 0.0])
    assert net_openings([0.4, 0.0, 0.0]) is None  # a malformed message is no signal
    signals = GloveSignals(NODES)
    signals.update('valve_command', net)
    assert 'u_net_pct=[40 -25 0]' in signals.line(now=0.0)


def test_a_record_of_commanded_steps_waits_for_the_plant_s_record_of_commands():
    # The run record's command is what the plant applied (applied_command), whose history a
    # monitor that matched the plant's states first gets only after some steps: those steps
    # wait for it, and each gets the command sent before its pressure, the vent the plant
    # started with here. Later commands join the steps they drove, by the time they were sent.
    signals = GloveSignals(NODES, commanded=True)
    early = [m for i, p in enumerate([1000.0, 2000.0, 3000.0]) for m in step_messages(i, p)]
    assert feed(signals, early) == []  # steps 0 and 1 joined, but no command known yet
    samples = signals.update('pressure_command', [0.0, 0.0, 0.0], published=999.0)
    assert [s.time for s in samples] == pytest.approx([0.0, PERIOD])
    command_sent = 1000.0 + 2.5 * PERIOD  # between step 2 and step 3
    assert signals.update('pressure_command', [5e3, 6e3, 7e3], published=command_sent) == []
    samples += feed(signals, step_messages(3, 4000.0) + step_messages(4, 5000.0))
    commands = [sample.values['pressure_command'] for sample in samples]
    np.testing.assert_array_equal(commands, [[0.0] * 3] * 3 + [[5e3, 6e3, 7e3]])


def test_steps_that_need_no_command_are_not_held_for_one():
    signals = GloveSignals(NODES)
    samples = run_steps(signals, [1000.0, 2000.0])
    assert all(sample.values['pressure_command'] is None for sample in samples)
