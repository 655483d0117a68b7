"""The emulated board over a real pseudo-terminal (exodigit_nodes.hardware.emulator), driven by
the host's link core: its samples are the glove behind valves of exodigit_model replayed
independently (within the sensor's quantisation), and its line and board faults do what
docs/spec/hardware.md says."""

import os
import subprocess
import sys
import time

import numpy as np
import pytest
from exodigit_nodes.hardware.board import VENT_DUTIES
from exodigit_nodes.hardware.emulator import BoardStatus
from exodigit_nodes.hardware.link import (
    Connected,
    HostLink,
    LinkLost,
    LinkSettings,
    LinkState,
    SampleReceived,
)
from exodigit_nodes.hardware.messages import Status, openings_of
from running_emulator import RunningEmulator

from exodigit_model import GloveSimulation, SimulationSettings

FILL = (6000, 3000, 10000, 0, 0, 0)
HOLD = (0, 0, 0, 0, 0, 0)
EMPTY = (0, 0, 0, 10000, 2000, 10000)


@pytest.fixture
def board(tmp_path, request):
    running = RunningEmulator(tmp_path, **getattr(request, 'param', {}))
    yield running
    running.stop()


def drive(link: HostLink, plan=None, *, samples: int = 0, seconds: float = 0.0) -> list:
    """Poll the link until ``samples`` samples came and ``seconds`` passed; the events.

    ``plan(sample_count)`` gives duties to send, or None. Counting samples, not seconds, keeps
    a test of the board's steps the same on a loaded machine (where it samples late).
    """
    events = []
    count = 0
    start = time.monotonic()
    end = start + seconds + (samples / 10.0 if samples else 0.0) + 10.0  # 10 Hz at the worst
    while count < samples or time.monotonic() - start < seconds:
        assert time.monotonic() < end, f'{count} of {samples} samples'
        for event in link.poll(time.monotonic()):
            events.append(event)
            if isinstance(event, SampleReceived):
                count += 1
                duties = plan(count) if plan else None
                if duties is not None:
                    link.send_openings(duties, time.monotonic())
        time.sleep(0.001)
    return events


def samples_of(events) -> list:
    return [e for e in events if isinstance(e, SampleReceived)]


@pytest.mark.parametrize('board', [dict(rate_hz=100, pressure_quantum=50, seed=3)], indirect=True)
def test_the_samples_are_the_model_behind_valves_within_the_quantisation(board):
    link = HostLink(LinkSettings(port=board.link))
    sent: dict[int, tuple] = {}

    def plan(count):
        duties = FILL if count < 40 else HOLD if count < 70 else EMPTY
        return duties if count % 3 == 0 else None  # a command every third sample

    def send_and_remember(count):
        duties = plan(count)
        if duties is not None:
            sent[link._sequence % 65535 + 1] = duties
        return duties

    events = drive(link, send_and_remember, samples=130)
    link.close()
    assert isinstance(events[0], Connected)
    samples = samples_of(events)
    assert link.lost_samples == 0
    replay = GloveSimulation(settings=SimulationSettings(rate_hz=100), actuation='valves')
    largest = 0.0
    for event in samples:
        sample = event.sample
        assert not sample.status & Status.WATCHDOG_VENT
        duties = VENT_DUTIES if sample.applied_sequence == 0 else sent[sample.applied_sequence]
        state = replay.step(openings_of(duties))
        # the sensor reads gauge pressure from 0 up (a chamber emptied below atmosphere reads 0)
        error = np.abs(np.array(sample.pressures_pa) - np.clip(state.pressure, 0.0, None))
        assert np.all(error <= 25.0 + 1e-6), (sample.sequence, sample.pressures_pa, state.pressure)
        angles = np.array(sample.angles) * 1e-4
        assert np.all(np.abs(angles - state.q) <= 5e-4 + 1e-9)  # quantum 10 × 1e-4 rad
        largest = max(largest, float(state.pressure.max()))
    assert largest > 20e3  # the chambers did fill


@pytest.mark.parametrize('board', [dict(latency=0.02)], indirect=True)
def test_the_round_trip_includes_the_latency_both_ways(board):
    link = HostLink(LinkSettings(port=board.link, handshake_timeout=3.0, sample_timeout=0.5))
    drive(link, lambda count: FILL if count % 5 == 0 else None, samples=100)
    link.close()
    assert link.round_trip.count >= 5
    assert link.round_trip.mean >= 0.04  # 20 ms each way, plus up to a sample period


@pytest.mark.parametrize(
    'board', [dict(corrupt_probability=2e-3, drop_probability=2e-3, seed=11)], indirect=True
)
def test_a_damaged_line_costs_frames_not_the_session(board):
    link = HostLink(LinkSettings(port=board.link, sample_timeout=0.5))
    events = drive(link, lambda count: FILL if count % 2 == 0 else None, samples=200)
    link.close()
    assert link.decoder.counts.bad + link.lost_samples > 0
    sent = samples_of(events)[-1].sample.sequence + 1  # the board's count since the Hello
    # a damaged frame (about 1 in 10 of 27 bytes at 2e-3 each) is lost, not more
    assert len(samples_of(events)) > 0.6 * sent
    assert link.sessions == 1


def test_a_silent_host_makes_the_board_vent(board):
    link = HostLink(LinkSettings(port=board.link))
    drive(link, lambda count: FILL if count == 5 else None, samples=10)
    filling = board.emulator.board.openings.copy()
    assert filling[0] == pytest.approx(0.6)
    time.sleep(0.5)  # the host says nothing: the board's watchdog (200 ms) vents
    assert list(board.emulator.board.openings) == list(openings_of(VENT_DUTIES))
    events = drive(link, samples=5)
    link.close()
    assert any(e.sample.status & Status.WATCHDOG_VENT for e in samples_of(events))


def test_supply_loss_is_flagged_and_no_air_comes_in(board):
    link = HostLink(LinkSettings(port=board.link))
    board.command('supply off')
    events = drive(link, lambda count: FILL, samples=60)
    link.close()
    samples = samples_of(events)
    assert all(s.sample.status & Status.SUPPLY_LOW for s in samples[5:])
    assert max(max(s.sample.pressures_pa) for s in samples) == 0


def test_a_stuck_inlet_fills_its_chamber_to_the_supply_whatever_is_commanded(board):
    link = HostLink(LinkSettings(port=board.link))
    board.command('stick 2 1')
    events = drive(link, lambda count: (0, 0, 0, 10000, 10000, 0), samples=150)
    link.close()
    samples = samples_of(events)
    assert max(s.sample.pressures_pa[2] for s in samples) > 90e3  # the supply is 100 kPa
    assert max(s.sample.pressures_pa[0] for s in samples) < 1e3  # vented, moved by DIP


@pytest.mark.parametrize('board', [dict(vent_pressure=30e3)], indirect=True)
def test_the_board_vents_a_chamber_at_its_vent_pressure(board):
    link = HostLink(LinkSettings(port=board.link))
    events = drive(link, lambda count: (10000, 10000, 10000, 0, 0, 0), samples=150)
    link.close()
    readings = np.array([s.sample.pressures_pa for s in samples_of(events)])
    flagged = [bool(s.sample.status & Status.OVER_PRESSURE) for s in samples_of(events)]
    over = readings >= 30e3
    assert over.any() and flagged == list(over.any(axis=1))
    # the step after a chamber reads at or above it, that chamber empties (and only then)
    after = np.diff(readings, axis=0)
    assert np.all(after[over[:-1]] < 0)
    assert readings.max() < 100e3 * 0.8  # far from the supply it would reach


def test_an_unplugged_board_is_found_again_and_starts_vented(board):
    link = HostLink(LinkSettings(port=board.link, reconnect_min=0.05, reconnect_max=0.2))
    drive(link, lambda count: FILL, samples=30)
    board.command('unplug 0.5')
    events = drive(link, seconds=0.3)
    lost = [e for e in events if isinstance(e, LinkLost)]
    assert lost and lost[0].state is LinkState.DISCONNECTED
    assert not os.path.exists(board.link)
    events = drive(link, samples=5)  # after the board is back
    link.close()
    assert any(isinstance(e, Connected) for e in events) and link.sessions == 2
    after = samples_of(events)
    assert after and after[0].sample.applied_sequence == 0  # vented, nothing applied yet


@pytest.mark.parametrize('board', [dict(version=2)], indirect=True)
def test_a_board_of_another_version_is_refused(board):
    from exodigit_nodes.hardware.link import IncompatibleBoardError

    link = HostLink(LinkSettings(port=board.link))
    with pytest.raises(IncompatibleBoardError, match='version 2'):
        drive(link, seconds=1.0)


def test_the_command_line_refuses_bad_values_and_has_help(tmp_path):
    run = [sys.executable, '-m', 'exodigit_nodes.hardware.emulator']
    helped = subprocess.run([*run, '--help'], capture_output=True, text=True, timeout=60)
    assert helped.returncode == 0 and 'unplug' in helped.stdout
    refused = subprocess.run(
        [*run, '--link', str(tmp_path / 'b'), '--rate-hz', '0'],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert refused.returncode == 2 and 'rate_hz = 0.0' in refused.stderr
    assert 'Traceback' not in refused.stderr


def test_the_status_line_reads_back_as_the_board_is(board):
    link = HostLink(LinkSettings(port=board.link))
    drive(link, lambda count: FILL, samples=20)
    link.close()
    status = board.emulator.status()
    assert status.streaming and status.openings == pytest.approx(openings_of(FILL))
    assert max(status.pressures) > 0 and not status.watchdog_tripped
    assert BoardStatus.parse(str(status)) == status
    with pytest.raises(ValueError, match='no status line'):
        BoardStatus.parse('refused: unknown command')
