"""How far a runner lets a simulated plant run ahead (exodigit_nodes.runner.horizon), without DDS.

The plant's parameter services are stand-ins that answer when the test says so; what is checked
is the rule of the module: ``run_until`` stays at most LEAD_STEPS past the newest step received,
is raised every RAISE_STEPS, never passes the end of the run, and a request whose answer was
lost is sent again.
"""

import itertools

import pytest
from exodigit_nodes.nodes import repeated_call
from exodigit_nodes.nodes.qos import RECORD_QOS, STREAM_QOS
from exodigit_nodes.nodes.repeated_call import RepeatedCall
from exodigit_nodes.runner.horizon import LEAD_STEPS, RAISE_STEPS, Horizon
from rcl_interfaces.msg import ParameterValue
from rclpy.task import Future

PERIOD = 0.01
READY_POLLS = 100
"""Most polls of Horizon.ready a test waits for: the stand-ins answer each request at once, so
three do (ask the rate, set the first limit, see it answered); a count, not a clock, because
some tests freeze time.monotonic."""


class StandInClient:
    """Records requests; answers each with ``respond`` unless told to lose it."""

    def __init__(self, respond):
        self.respond = respond
        self.requests = []
        self.removed = []
        self.lose_next = 0

    def service_is_ready(self):
        return True

    def call_async(self, request):
        self.requests.append(request)
        future = Future()
        if self.lose_next:
            self.lose_next -= 1
        else:
            future.set_result(self.respond(request))
        return future

    def remove_pending_request(self, future):
        self.removed.append(future)


class StandInNode:
    def __init__(self):
        self.clients = {}

    def create_client(self, service_type, name):
        def respond(request):
            response = service_type.Response()
            if hasattr(request, 'names'):  # get_parameters: the plant's rate_hz
                response.values = [ParameterValue(double_value=1.0 / PERIOD)]
            return response

        client = StandInClient(respond)
        self.clients[name.rsplit('/', 1)[-1]] = client
        return client


def wait_ready(hold):
    """Poll ``hold.ready`` until it is; fail the test after READY_POLLS polls (never hang)."""
    for _ in range(READY_POLLS):
        if hold.ready(0.0):
            return
    pytest.fail(f'Horizon.ready still false after {READY_POLLS} polls of answering stand-ins')


def limits(client):
    return [request.parameters[0].value.double_value for request in client.requests]


def test_a_lost_answer_is_asked_again_after_the_resend_period(monkeypatch):
    client = StandInClient(lambda request: 'answer')
    client.lose_next = 1
    now = [100.0]
    monkeypatch.setattr(repeated_call.time, 'monotonic', lambda: now[0])
    call = RepeatedCall(client, 'request')
    assert call.answer() is None and len(client.requests) == 1
    now[0] += repeated_call.RESEND / 2
    assert call.answer() is None and len(client.requests) == 1  # not yet overdue
    now[0] += repeated_call.RESEND
    assert call.answer() is None  # sent again now, answered this time
    assert len(client.requests) == 2 and len(client.removed) == 1
    assert call.answer() == 'answer'


def test_the_first_limit_waits_for_the_rate_and_lies_lead_steps_ahead():
    node = StandInNode()
    hold = Horizon(node, '/glove/plant')
    hold.start(0.0)
    wait_ready(hold)
    assert hold.period == pytest.approx(PERIOD)
    assert [r.names for r in node.clients['get_parameters'].requests] == [['rate_hz']]
    assert limits(node.clients['set_parameters']) == pytest.approx([LEAD_STEPS * PERIOD])


def test_the_lead_is_shorter_than_what_each_publisher_and_each_recording_reader_keeps():
    # one step in flight beyond the lead must still be in every publisher's history, and a
    # recording reader must have room for all of them
    assert STREAM_QOS.depth >= LEAD_STEPS + 1
    assert RECORD_QOS.depth >= LEAD_STEPS + 1
    assert 0 < RAISE_STEPS < LEAD_STEPS


@pytest.mark.parametrize('ends', [False, True], ids=['open', 'end'])
def test_the_limit_follows_the_steps_received_and_stops_at_the_end(ends):
    lead, raise_every = LEAD_STEPS, RAISE_STEPS
    end_steps = 2.5 * lead if ends else 0
    end = end_steps * PERIOD
    node = StandInNode()
    hold = Horizon(node, '/glove/plant', period=PERIOD)
    hold.start(end)
    wait_ready(hold)
    setter = node.clients['set_parameters']
    steps = round(end_steps) if end else 3 * lead  # the plant is held at the run's end
    for k in range(1, steps + 1):  # it takes a step only while the limit allows it
        received = k * PERIOD
        assert received <= limits(setter)[-1] + 1e-12
        hold.follow(received)
        assert limits(setter)[-1] - received <= lead * PERIOD + 1e-12
    sent = limits(setter)
    raises = [round(b / PERIOD) - round(a / PERIOD) for a, b in itertools.pairwise(sent)]
    if end:
        assert sent[-1] == pytest.approx(end) and max(sent) == pytest.approx(end)
        raises = raises[:-1]  # the last raise stops at the end
    assert raises and set(raises) == {raise_every}


def test_release_sends_no_limit_after_every_raise_on_the_same_client(monkeypatch):
    now = [100.0]
    monkeypatch.setattr(repeated_call.time, 'monotonic', lambda: now[0])
    node = StandInNode()
    hold = Horizon(node, '/glove/plant', period=PERIOD)
    hold.start(0.0)
    wait_ready(hold)
    setter = node.clients['set_parameters']
    setter.lose_next = 1  # the answer to the next raise is lost
    hold.follow(RAISE_STEPS * PERIOD)
    raised = limits(setter)
    assert len(raised) == 2
    call = hold.release()  # drops the raise whose answer was lost: never sent again
    now[0] += 10 * repeated_call.RESEND
    assert call.answer() is not None and hold.limit == 0.0
    assert limits(setter) == [*raised, 0.0]  # after every raise, on the client that raised it
    assert list(node.clients) == ['set_parameters']  # no client of its own for the release
    assert not hold.ready(0.0)  # a new run sets its first limit again
