"""What the transport loses and how long it stalls, with and without the project's DDS profile.

Each case runs twice, once with ``FASTRTPS_DEFAULT_PROFILES_FILE`` naming
``exodigit_nodes/nodes/fastdds.xml`` (:mod:`exodigit_nodes.nodes.dds`) and once with no profile
(Fast DDS's defaults), every process in a domain of its own with discovery on loopback:

1. **Many topics into one starved process.** A publisher process sends ``--topics`` topics at
   ``--rate`` Hz each (Float64MultiArray, the glove's QoS: reliable, keep-last 10), each message
   carrying its sequence number. A subscriber process (the glove's QoS, or keep-all with
   ``RECORD_QOS`` depth as a recorder) takes them all. Every ``--period`` s the benchmark
   stops the subscriber with SIGSTOP for ``--starve`` s, as a loaded machine or a long callback
   would. Printed: samples lost (sequence numbers never received), the longest stall (the longest
   time between two arrivals on one topic while the publisher kept publishing, outside the
   stops), and samples that arrived only after a stall of more than 100 ms.
2. **Service calls from fresh clients.** A server process answers std_srvs/Trigger; the
   benchmark process, ``--calls`` times, creates a new client, waits for the service and calls
   it at once, as ``ros2 service call`` and a test's first call do. Printed: answers that did
   not come within 2 s (dropped by the server when the client's reply reader had not matched in
   time, ros2/ros2#1253).

Run: ``.venv/bin/python benchmarks/bench_transport.py [--seconds 20] [--topics 8] [--rate 200]``
(``--case 1`` or ``--case 2`` for one case). Figures depend on the machine's load: run it idle
and beside busy processes, and compare the two configurations within one run.
"""

import argparse
import contextlib
import itertools
import json
import os
import signal
import subprocess
import sys
import time

import rclpy
from exodigit_nodes.nodes.dds import PROFILE, PROFILE_VARIABLE
from exodigit_nodes.nodes.qos import READER_QOS, RECORD_QOS, STREAM_QOS
from exodigit_nodes.testing import claim_domain
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

#: Publishers' QoS: the glove's (keep-last 1,000), keep-last 10 as they had before, keep-all.
WRITERS = {
    'glove': STREAM_QOS,
    'keep-last-10': READER_QOS,
    'keep-all': QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        reliability=STREAM_QOS.reliability,
        durability=STREAM_QOS.durability,
    ),
}
#: A stall longer than this counts in "late samples", s.
LATE = 0.1
#: How long a fresh client waits for its answer before it counts as dropped, s.
ANSWER_TIMEOUT = 2.0


def publish(topics: int, rate: float, seconds: float, writer: str) -> None:
    """The publisher process: ``topics`` topics at ``rate`` Hz, sequence number in data[0]."""
    rclpy.init()
    node = rclpy.create_node('bench_publisher')
    qos = WRITERS[writer]
    publishers = [
        node.create_publisher(Float64MultiArray, f'bench_{i}', qos) for i in range(topics)
    ]
    time.sleep(2.0)  # discovery
    start = time.monotonic()
    sequence = 0
    longest = 0.0
    while time.monotonic() - start < seconds:
        for publisher in publishers:
            before = time.monotonic()
            publisher.publish(Float64MultiArray(data=[float(sequence), 0.0, 0.0, 0.0]))
            longest = max(longest, time.monotonic() - before)
        sequence += 1
        time.sleep(max(0.0, start + sequence / rate - time.monotonic()))
    print(json.dumps({'sent': sequence, 'longest_publish_s': longest}), flush=True)
    time.sleep(1.0)  # let the last heartbeats repair what is missing
    node.destroy_node()
    rclpy.shutdown()


def subscribe(topics: int, seconds: float, keep_all: bool) -> None:
    """The subscriber process: records (topic, sequence, arrival) until ``seconds`` pass."""
    rclpy.init()
    node = rclpy.create_node('bench_subscriber')
    arrivals: list[list[tuple[int, float]]] = [[] for _ in range(topics)]

    def taker(index):
        return lambda message: arrivals[index].append((int(message.data[0]), time.monotonic()))

    qos = RECORD_QOS if keep_all else READER_QOS
    for i in range(topics):
        node.create_subscription(Float64MultiArray, f'bench_{i}', taker(i), qos)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    end = time.monotonic() + seconds
    print('ready', flush=True)
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    print(json.dumps(arrivals), flush=True)
    node.destroy_node()
    rclpy.shutdown()


def serve() -> None:
    """The server process: answers Trigger until stopped."""
    rclpy.init()
    node = rclpy.create_node('bench_server')
    node.create_service(Trigger, 'bench_trigger', lambda request, response: response)
    print('ready', flush=True)
    with contextlib.suppress(KeyboardInterrupt):
        rclpy.spin(node)


def environment(profile: bool, domain: int) -> dict[str, str]:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID=str(domain))
    env.pop(PROFILE_VARIABLE, None)
    if profile:
        env[PROFILE_VARIABLE] = str(PROFILE)
    return env


def child(role: str, env: dict[str, str], *arguments) -> subprocess.Popen:
    command = [sys.executable, __file__, '--role', role, *map(str, arguments)]
    return subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True)


def starved_topics(args, profile: bool, domain: int) -> dict:
    """Case 1 for one configuration: lost samples, longest stall, late samples."""
    env = environment(profile, domain)
    listen = args.seconds + 6.0
    subscriber = child('subscribe', env, args.topics, listen, int(args.keep_all))
    assert subscriber.stdout.readline().strip() == 'ready'
    publisher = child('publish', env, args.topics, args.rate, args.seconds, args.writer)
    stops = []
    time.sleep(2.5)  # the publisher's discovery pause
    began = time.monotonic()
    while time.monotonic() - began < args.seconds - args.starve:
        time.sleep(args.period)
        stopped = time.monotonic()
        subscriber.send_signal(signal.SIGSTOP)
        time.sleep(args.starve)
        subscriber.send_signal(signal.SIGCONT)
        stops.append((stopped, time.monotonic()))
    published = json.loads(publisher.stdout.readline())
    sent = published['sent']
    publisher.wait()
    arrivals = json.loads(subscriber.stdout.readline())
    subscriber.wait()
    lost = sum(sent - len({sequence for sequence, _ in topic}) for topic in arrivals)
    longest, late = 0.0, 0
    for topic in arrivals:
        for (_, before), (_, after) in itertools.pairwise(topic):
            # the time the subscriber could run between the two arrivals
            gap = after - before
            gap -= sum(max(0.0, min(after, end) - max(before, start)) for start, end in stops)
            longest = max(longest, gap)
            late += gap > LATE
    return {
        'sent': sent * args.topics,
        'lost': lost,
        'longest_stall_s': round(longest, 4),
        'late': late,
        'longest_publish_s': round(published['longest_publish_s'], 4),
    }


def call(calls: int) -> None:
    """The caller process: ``calls`` fresh clients, each calling once; prints the dropped."""
    rclpy.init()
    node = rclpy.create_node('bench_caller')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    dropped = 0
    for _ in range(calls):
        client = node.create_client(Trigger, 'bench_trigger')
        while not client.wait_for_service(timeout_sec=0.1):
            executor.spin_once(timeout_sec=0.0)
        future = client.call_async(Trigger.Request())
        executor.spin_until_future_complete(future, timeout_sec=ANSWER_TIMEOUT)
        dropped += not future.done()
        node.destroy_client(client)
    print(json.dumps({'calls': calls, 'dropped': dropped}), flush=True)
    node.destroy_node()
    rclpy.shutdown()


def fresh_clients(args, profile: bool, domain: int) -> dict:
    """Case 2 for one configuration (a process of its own: Fast DDS reads profiles once)."""
    env = environment(profile, domain)
    server = child('serve', env)
    assert server.stdout.readline().strip() == 'ready'
    caller = child('call', env, args.calls)
    result = json.loads(caller.stdout.readline())
    caller.wait()
    server.send_signal(signal.SIGINT)
    server.wait()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument(
        '--role', choices=('publish', 'subscribe', 'serve', 'call'), help=argparse.SUPPRESS
    )
    parser.add_argument('values', nargs='*', help=argparse.SUPPRESS)
    parser.add_argument('--case', type=int, choices=(1, 2), help='run one case only')
    parser.add_argument('--seconds', type=float, default=20.0, help='publishing time, s')
    parser.add_argument('--topics', type=int, default=8, help='topics of case 1')
    parser.add_argument('--rate', type=float, default=200.0, help='rate of each topic, Hz')
    parser.add_argument('--period', type=float, default=2.0, help='time between stops, s')
    parser.add_argument('--starve', type=float, default=0.3, help='length of a stop, s')
    parser.add_argument('--keep-all', action='store_true', help='subscribe as a recorder')
    parser.add_argument(
        '--writer',
        choices=tuple(WRITERS),
        default='glove',
        help="publishers' history: the glove's keep-last 1,000 (default), keep-last 10 (the "
        "glove's before) or keep-all (Fast DDS keeps up to 5,000, then blocks, then fails)",
    )
    parser.add_argument('--calls', type=int, default=50, help='fresh clients of case 2')
    args = parser.parse_args()
    if args.role == 'publish':
        topics, rate, seconds, writer = args.values
        return publish(int(topics), float(rate), float(seconds), writer)
    if args.role == 'subscribe':
        return subscribe(int(args.values[0]), float(args.values[1]), bool(int(args.values[2])))
    if args.role == 'serve':
        return serve()
    if args.role == 'call':
        return call(int(args.values[0]))
    lease = claim_domain()
    try:
        for case, run in ((1, starved_topics), (2, fresh_clients)):
            if args.case not in (None, case):
                continue
            for profile in (True, False):
                label = 'exodigit profile' if profile else 'Fast DDS defaults'
                result = run(args, profile, lease.domain_id)
                print(f'case {case}, {label}: {json.dumps(result)}', flush=True)
    finally:
        lease.release()


if __name__ == '__main__':
    main()
