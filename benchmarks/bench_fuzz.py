"""Fuzz figures of issue 4: every input topic of the running glove flooded with hostile messages.

Starts the three nodes as processes (on a free ROS domain, loopback discovery) and, topic by topic,
publishes ``--count`` hostile messages at full speed (wrong lengths, NaN, ±Inf, ±1e308, subnormals,
negative and huge values, bad joint names, mismatched JointState arrays, zero, future and ancient
stamps; see tests/reliability_fuzz.py). Prints per topic: messages tried and how many were
malformed, flood time, crashes (a node died or logged a traceback), non-finite and out-of-limit
outputs, unsafe commands (outside [0, max_pressure] or changing faster than max_pressure_rate),
rejections each consumer counted in /diagnostics, drop warnings it logged; then each node's
resident-memory growth over the whole run.

Run: ``.venv/bin/python benchmarks/bench_fuzz.py [--count 10000]``. The test suite runs the
same floods with 2,000 messages per topic (tests/test_reliability_fuzz.py).
"""

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'tests'))

from reliability_fuzz import TARGETS, GloveUnderFuzz
from ros_harness import DISCOVERY_TIMEOUT, NodeLauncher, RosProbe, claim_domain

START_TIMEOUT = 30.0


def main(argv=None) -> int:
    """Run the floods and print the figures; exit 1 if anything broke."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--count', type=int, default=10000, help='messages per topic')
    args = parser.parse_args(argv)
    lease = claim_domain()
    probe = RosProbe(lease.domain_id, 'bench_fuzz_probe')
    with tempfile.TemporaryDirectory(prefix='bench_fuzz_') as workdir:
        launcher = NodeLauncher(lease.domain_id, Path(workdir))
        try:
            glove = GloveUnderFuzz(launcher, probe)
            if not glove.wait_running(START_TIMEOUT + DISCOVERY_TIMEOUT):
                print('bench_fuzz: the glove did not start', file=sys.stderr)
                return 1
            rss_before = glove.rss()
            rows = [glove.flood(target, args.count, seed=i) for i, target in enumerate(TARGETS)]
            rss_after = glove.rss()
        finally:
            launcher.stop_all()
            probe.close()
            lease.release()
    bad = 0
    header = (
        'topic',
        'sent',
        'malformed',
        's',
        'crashes',
        'non-finite',
        'out of limits',
        'unsafe',
    )
    widths = (26, 6, 9, 5, 7, 10, 13, 6)
    cells = [
        f'{h:{w}s}' if i == 0 else f'{h:>{w}s}'
        for i, (h, w) in enumerate(zip(header, widths, strict=True))
    ]
    print(' '.join(cells) + '  rejections counted / drop warnings logged')
    for row in rows:
        crashes = len({n for n, alive in row.alive.items() if not alive} | set(row.tracebacks))
        counted = ', '.join(
            f'{n} {row.rejections[n]} / {row.log_lines[n]} lines' for n in row.rejections
        )
        print(
            f'{row.topic:26s} {row.sent:6d} {row.malformed:9d} {row.seconds:5.1f} {crashes:7d} '
            f'{row.outputs.non_finite:10d} {row.outputs.out_of_bounds:13d} '
            f'{len(row.unsafe_commands):6d}  {counted}'
        )
        bad += (
            crashes + row.outputs.non_finite + row.outputs.out_of_bounds + len(row.unsafe_commands)
        )
    print('\nresident memory (MiB) before -> after all floods:')
    for name, before in rss_before.items():
        if name in glove.restarted or name not in rss_after:
            print(f'  {name:18s} crashed during the floods: not comparable')
            bad += 1
            continue
        growth = 100.0 * (rss_after[name] / before - 1.0)
        mib = before / 2**20, rss_after[name] / 2**20
        print(f'  {name:18s} {mib[0]:7.1f} -> {mib[1]:7.1f} ({growth:+.1f}%)')
        bad += growth > 10.0
    return 1 if bad else 0


if __name__ == '__main__':
    raise SystemExit(main())
