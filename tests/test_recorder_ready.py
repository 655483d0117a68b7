"""The recorder's ``~/ready`` (docs/tools.md, "Recording a session"): it says True only once
the plant of every glove it records has answered it, which it does only after matching all the
recorder's readers. The runners start their plants only then: a plant in simulated time that
ends its session before it knows of the recorder takes every sample with it (a CI run's hand bag
held no message of one finger).

The recorder records two gloves; the second one's plant starts only after the first one's
outputs have reached the recorder (its log says so): until then no ready, then ready.
"""

from exodigit_nodes.nodes.qos import HANDED_OVER_QOS
from ros_harness import wait_until
from std_msgs.msg import Bool

NS = '/recorder_ready'
#: Longest wait for a node to start and be discovered, s (a failing test waits it out).
TIMEOUT = 30.0
PLANT = {'rate_hz': 20.0, 'marker_rate_hz': 0.0}


def test_the_recorder_is_ready_only_once_the_plant_of_every_glove_answered_it(
    launcher, probe, tmp_path
):
    ready = probe.subscribe(f'{NS}/recorder/ready', Bool, qos=HANDED_OVER_QOS)
    recorder = launcher.start(
        'recorder',
        None,
        namespace=NS,
        arguments=['--output', str(tmp_path / 'bags'), '--gloves', 'a,b'],
    )
    launcher.start('plant', PLANT, namespace=f'{NS}/a')
    heard = f'first message on {NS}/a/joint_states'
    assert wait_until(lambda: heard in recorder.stderr(), TIMEOUT), recorder.stderr()
    # glove b has no plant yet: not ready (the recorder logs it when it says it)
    assert ': ready' not in recorder.stderr()
    assert ready.count() == 0
    launcher.start('plant', PLANT, namespace=f'{NS}/b')
    assert wait_until(lambda: ready.count() == 1, TIMEOUT), recorder.stderr()
    assert ready.latest().data is True
    assert "every plant has matched the recorder's readers: ready" in recorder.stderr()
