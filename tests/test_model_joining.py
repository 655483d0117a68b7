"""exodigit_model.stepping.joining: pairing the samples of several streams by their send times.

Every sample's value names the plant step it belongs to, so a group is right exactly when all its
values are equal; the data are built so that the tempting shortcuts (nearest times, sequence
numbers) would get them wrong.
"""

import math

import numpy as np
import pytest
from exodigit_model.stepping.joining import MAX_WAITING, STEP_TOLERANCE
from hypothesis import given, settings
from hypothesis import strategies as st

from exodigit_model import Joined, Joiner, join_indices

PERIOD = 0.01  # s, a 100 Hz plant
STREAMS = ('chamber_pressure', 'joint_states', 'contact_forces')


def plant_steps(gaps, spacings, start=1000.0):
    """(stream, sent, step) of a plant publishing pressure, angles, forces in each step.

    ``gaps[k]``: how long after its pressure step k's angles are sent (the plant preempted
    between two publications); the forces follow the angles 50 µs later; ``spacings[k]``: from
    step k's forces to step k+1's pressure (small when a late plant catches up).
    """
    messages, sent = [], start
    for step, (gap, spacing) in enumerate(zip(gaps, spacings, strict=True)):
        messages.append(('chamber_pressure', sent, step))
        messages.append(('joint_states', sent + gap, step))
        messages.append(('contact_forces', sent + gap + 50e-6, step))
        sent += gap + 50e-6 + spacing
    return messages


def feed(joiner, messages, order=None):
    """Offer ``messages`` (in ``order``: default by time sent); all groups they complete."""
    ordered = sorted(messages, key=lambda m: m[1]) if order is None else order
    groups = []
    for stream, sent, value in ordered:
        groups += joiner.add(stream, sent, value)
    return groups


def steps_of(groups):
    """The step of each group, or None for a group that mixes steps."""
    return [
        group.values['chamber_pressure'] if len(set(group.values.values())) == 1 else None
        for group in groups
    ]


def nearest_steps(messages, lead, other):
    """The step a nearest-time rule would pair with each ``lead`` sample."""
    leads = [(t, v) for s, t, v in messages if s == lead]
    others = [(t, v) for s, t, v in messages if s == other]
    return [min(others, key=lambda o: abs(o[0] - t))[1] for t, _ in leads]


# Step 3's angles are sent 27 ms after its pressure (the worst measured on an overloaded
# machine); steps 3 to 6 then follow 0.5 ms apart (the plant catching up).
GAPS = [50e-6] * 3 + [27e-3] + [50e-6] * 6
SPACINGS = [PERIOD] * 3 + [0.5e-3] * 4 + [PERIOD] * 3


@pytest.mark.parametrize('confirm', [False, True])
def test_each_step_joins_however_late_its_angles_are_sent(confirm):
    messages = plant_steps(GAPS, SPACINGS)
    assert nearest_steps(messages, 'chamber_pressure', 'joint_states') != list(range(10))
    joiner = Joiner(STREAMS, confirm=confirm)
    groups = feed(joiner, messages)
    if confirm:
        assert steps_of(groups) == list(range(9))  # the last waits for the next pressure
        groups += joiner.flush()
    assert steps_of(groups) == list(range(10))
    assert joiner.unpaired == 0
    sent = {(s, v): t for s, t, v in messages}
    assert [g.time for g in groups] == [sent['chamber_pressure', k] for k in range(10)]


def test_each_step_joins_whatever_order_its_topics_arrive_in():
    # Each topic in its own order (as DDS delivers one publisher), one topic far ahead.
    messages = plant_steps([50e-6] * 6, [PERIOD] * 6)
    by_topic = sorted(messages, key=lambda m: (STREAMS[::-1].index(m[0]), m[1]))
    joiner = Joiner(STREAMS, confirm=True)
    assert steps_of(feed(joiner, messages, by_topic) + joiner.flush()) == list(range(6))


def test_a_replayed_bag_joins_like_the_session_though_its_sequence_numbers_restart():
    # The session, recorded; the bag started between a step's pressure and its angles, so the
    # player numbers the angles of step 1 and the pressure of step 2 both 1.
    session = plant_steps([50e-6] * 8, [PERIOD] * 8)
    bag = session[4:]  # from step 1's angles on
    sequence = {s: [v for x, _, v in bag if x == s] for s in STREAMS}
    by_number = list(zip(sequence['chamber_pressure'], sequence['joint_states'], strict=False))
    assert any(p != q for p, q in by_number)  # pairing by sequence number mixes steps
    replay = [(s, t + 3600.0, v) for s, t, v in bag]  # played an hour later, on the player's clock
    joiner = Joiner(STREAMS)
    assert steps_of(feed(joiner, session)) == list(range(8))
    assert steps_of(feed(joiner, replay)) == list(range(2, 8))
    assert steps_of(feed(joiner, bag)) == list(range(2, 8))  # played again: time goes back
    assert joiner.unpaired > 0  # the replay's first angles, without their pressure


def test_pressure_at_50_hz_pairs_with_the_angles_sent_after_it_at_100_hz():
    angles = [('joint_states', 1000.0 + PERIOD * k + 50e-6, k) for k in range(20)]
    pressures = [('chamber_pressure', 1000.0 + PERIOD * k, k) for k in range(0, 20, 2)]
    joiner = Joiner(('chamber_pressure', 'joint_states'))
    groups = feed(joiner, angles + pressures)
    assert steps_of(groups) == list(range(0, 20, 2))
    assert joiner.unpaired == 9  # the angles between two pressures (the last may still pair)


def test_angles_at_50_hz_pair_with_the_pressure_before_them_only():
    pressures = [('chamber_pressure', 1000.0 + PERIOD * k, k) for k in range(20)]
    angles = [('joint_states', 1000.0 + PERIOD * k + 50e-6, k) for k in range(0, 20, 2)]
    joiner = Joiner(('chamber_pressure', 'joint_states'), confirm=True)
    assert steps_of(feed(joiner, angles + pressures) + joiner.flush()) == list(range(0, 20, 2))


def test_a_recorder_that_joined_between_two_publications_pairs_from_the_next_step():
    session = plant_steps([50e-6] * 6, [PERIOD] * 6)
    recorded = session[1:]  # started after step 0's pressure, before its angles
    joiner = Joiner(STREAMS, confirm=True)
    assert steps_of(feed(joiner, recorded) + joiner.flush()) == list(range(1, 6))
    assert joiner.unpaired == 2
    pressure = [t for s, t, _ in recorded if s == 'chamber_pressure']
    angles = [t for s, t, _ in recorded if s == 'joint_states']
    assert join_indices(pressure, angles).tolist() == [1, 2, 3, 4, 5]


def test_a_topic_subscribed_two_steps_late_pairs_nothing_with_the_earlier_steps():
    session = plant_steps([50e-6] * 6, [PERIOD] * 6)
    late = [m for m in session if m[0] == 'chamber_pressure' or m[2] >= 2]
    joiner = Joiner(STREAMS)
    assert steps_of(feed(joiner, late)) == [2, 3, 4, 5]


@pytest.mark.parametrize('lost', ['joint_states', 'contact_forces', 'chamber_pressure'])
def test_a_step_that_lost_a_message_is_skipped(lost):
    session = plant_steps([50e-6] * 6, [PERIOD] * 6)
    kept = [m for m in session if m[:3:2] != (lost, 3)]
    joiner = Joiner(STREAMS)
    assert steps_of(feed(joiner, kept)) == [0, 1, 2, 4, 5]
    assert joiner.unpaired == 2  # the other two messages of step 3


def test_a_refused_sample_keeps_its_place():
    session = plant_steps([50e-6] * 4, [PERIOD] * 4)
    refused = [(s, t, None if (s, v) == ('joint_states', 2) else v) for s, t, v in session]
    groups = feed(Joiner(STREAMS), refused)
    assert [g.values['joint_states'] for g in groups] == [0, 1, None, 3]
    assert steps_of(groups[:2] + groups[3:]) == [0, 1, 3]


def test_a_partner_sent_later_than_the_tolerance_pairs_with_nothing():
    joiner = Joiner(('chamber_pressure', 'joint_states'), tolerance=0.02)
    assert joiner.add('chamber_pressure', 10.0, 'p') == []
    assert joiner.add('joint_states', 10.03, 'q') == []
    assert joiner.unpaired == 1
    assert joiner.add('chamber_pressure', 10.04, 'p2') == []
    assert joiner.add('joint_states', 10.04, 'q2') == [
        Joined(10.04, {'chamber_pressure': 'p2', 'joint_states': 'q2'})
    ]
    assert join_indices([10.0, 10.04], [10.03, 10.04], tolerance=0.02).tolist() == [-1, 1]


def test_a_silent_stream_holds_a_bounded_number_of_samples():
    joiner = Joiner(('chamber_pressure', 'joint_states'))
    for k in range(MAX_WAITING + 40):
        assert joiner.add('chamber_pressure', PERIOD * k, k) == []
    assert joiner.unpaired == 40
    assert joiner.add('joint_states', PERIOD * (MAX_WAITING + 39), 'q')  # the newest pairs


@st.composite
def streams_and_arrival(draw):
    """Sorted times of a lead and two other streams, and an arrival order keeping each's order."""
    times = {
        name: sorted(draw(st.lists(st.integers(0, 60), max_size=15)))
        for name in ('lead', 'a', 'b')
    }
    tickets = [name for name, values in times.items() for _ in values]
    arrival = draw(st.permutations(tickets))
    return {name: [t * 1e-3 for t in values] for name, values in times.items()}, arrival


def expected_groups(times, tolerance):
    """The groups join_indices gives: (lead index, partner index per stream) with all partners."""
    partners = {s: join_indices(times['lead'], times[s], tolerance=tolerance) for s in ('a', 'b')}
    return [
        (i, partners['a'][i], partners['b'][i])
        for i in range(len(times['lead']))
        if partners['a'][i] >= 0 and partners['b'][i] >= 0
    ]


@settings(max_examples=300, deadline=None)
@given(streams_and_arrival(), st.sampled_from([5e-3, 0.02, STEP_TOLERANCE]))
def test_online_with_confirm_gives_join_indices_in_any_arrival_order(case, tolerance):
    times, arrival = case
    joiner = Joiner(('lead', 'a', 'b'), tolerance=tolerance, confirm=True)
    index = dict.fromkeys(times, 0)
    groups = []
    for name in arrival:
        groups += joiner.add(name, times[name][index[name]], index[name])
        index[name] += 1
    groups += joiner.flush()
    found = [(g.values['lead'], g.values['a'], g.values['b']) for g in groups]
    assert found == expected_groups(times, tolerance)


@settings(max_examples=300, deadline=None)
@given(streams_and_arrival())
def test_online_gives_join_indices_when_samples_arrive_in_the_order_they_were_sent(case):
    times, _ = case
    messages = [(name, t, i) for name, values in times.items() for i, t in enumerate(values)]
    # At equal times the lead is sent first, as the plant sends a step's pressure first.
    messages.sort(key=lambda m: (m[1], m[0] != 'lead'))
    groups = feed(Joiner(('lead', 'a', 'b')), messages, messages)
    found = [(g.values['lead'], g.values['a'], g.values['b']) for g in groups]
    assert found == expected_groups(times, STEP_TOLERANCE)


def test_join_indices_on_no_partner_samples():
    assert join_indices([1.0, 2.0], []).tolist() == [-1, -1]
    assert join_indices([], [1.0]).tolist() == []


@pytest.mark.parametrize(
    ('arguments', 'message'),
    [
        ({'streams': ['p']}, 'two or more'),
        ({'streams': ['p', 'p']}, 'two or more'),
        ({'streams': ['p', 'q'], 'tolerance': 0.0}, 'tolerance'),
        ({'streams': ['p', 'q'], 'tolerance': math.inf}, 'tolerance'),
    ],
)
def test_a_joiner_refuses_bad_settings(arguments, message):
    with pytest.raises(ValueError, match=message):
        Joiner(**arguments)


def test_a_joiner_refuses_unknown_streams_and_times_that_are_not_finite():
    joiner = Joiner(('p', 'q'))
    with pytest.raises(ValueError, match='unknown stream'):
        joiner.add('r', 1.0, None)
    with pytest.raises(ValueError, match='finite'):
        joiner.add('p', math.nan, None)


@pytest.mark.parametrize('times', [[2.0, 1.0], [[1.0]], [1.0, math.nan]])
def test_join_indices_refuses_times_out_of_order(times):
    with pytest.raises(ValueError, match='non-decreasing'):
        join_indices(times, [1.0])
    with pytest.raises(ValueError, match='non-decreasing'):
        join_indices(np.array([1.0]), times)
