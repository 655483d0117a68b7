"""``~/ready`` (exodigit_nodes/nodes/handshake.py; docs/tools.md, "Recording a session"): the
recorder and the estimator say True only once the plant of every glove they listen to has
answered them, which it does only after matching all their readers.

What waits for it: the runners start their plants only once the recorder is ready (a plant in
simulated time that ends its session before it knows of the recorder takes every sample with
it: a CI run's hand bag held no message of one finger); the testing kit steps only once the
estimator is (a state the plant sent before it knew of the estimator was never estimated, and
the kit's first reset waited for that estimate in vain).

Each node starts first, alone: no ready (its log would say it, and after a few seconds it says
which plant it waits for); then the plants: ready.
"""

from exodigit_nodes.nodes.qos import HANDED_OVER_QOS
from ros_harness import wait_until
from std_msgs.msg import Bool

NS = '/readiness'
#: Longest wait for a node to start and be discovered, s (a failing test waits it out).
TIMEOUT = 30.0
PLANT = {'rate_hz': 20.0, 'marker_rate_hz': 0.0}
READY_LINE = 'every node we listen to has matched our readers: ready'


def test_the_recorder_is_ready_only_once_the_plant_of_every_glove_answered_it(
    launcher, probe, tmp_path
):
    ns = f'{NS}/hand'
    ready = probe.subscribe(f'{ns}/recorder/ready', Bool, qos=HANDED_OVER_QOS)
    recorder = launcher.start(
        'recorder',
        None,
        namespace=ns,
        arguments=['--output', str(tmp_path / 'bags'), '--gloves', 'a,b'],
    )
    launcher.start('plant', PLANT, namespace=f'{ns}/a')
    heard = f'first message on {ns}/a/joint_states'
    assert wait_until(lambda: heard in recorder.stderr(), TIMEOUT), recorder.stderr()
    assert READY_LINE not in recorder.stderr()  # glove b has no plant yet
    assert ready.count() == 0
    launcher.start('plant', PLANT, namespace=f'{ns}/b')
    assert wait_until(lambda: ready.count() == 1, TIMEOUT), recorder.stderr()
    assert ready.latest().data is True
    assert wait_until(lambda: READY_LINE in recorder.stderr(), TIMEOUT)  # the log says it too


def test_the_estimator_is_ready_only_once_the_plant_beside_it_answered_it(launcher, probe):
    ns = f'{NS}/glove'
    ready = probe.subscribe(f'{ns}/estimator/ready', Bool, qos=HANDED_OVER_QOS)
    estimator = launcher.start('estimator', {}, namespace=ns)
    assert wait_until(lambda: 'estimator: model from' in estimator.stderr(), TIMEOUT)
    assert READY_LINE not in estimator.stderr()  # no plant yet
    assert ready.count() == 0
    # after a while the log says whom it waits for
    waiting = f'not ready: no answer yet from {ns}/plant/get_parameters'
    assert wait_until(lambda: waiting in estimator.stderr(), TIMEOUT), estimator.stderr()
    assert ready.count() == 0
    launcher.start('plant', PLANT, namespace=ns)
    assert wait_until(lambda: ready.count() == 1, TIMEOUT), estimator.stderr()
    assert ready.latest().data is True
    assert wait_until(lambda: READY_LINE in estimator.stderr(), TIMEOUT)  # the log says it too
