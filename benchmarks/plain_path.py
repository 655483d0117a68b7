"""The plain-Python side of a benchmark: the same script re-run with ``EXODIGIT_JIT=0``.

A benchmark script that takes ``--plain`` prints its timings as one JSON line (with ``jit``: the
path it ran on); :func:`run_plain` runs it so, in a subprocess, and returns that line.
"""

import json
import os
import subprocess
import sys


def run_plain(script: str, repeats: int, options: list[str] | None = None) -> dict:
    """The timings ``script`` prints with ``--plain --repeats repeats`` and ``EXODIGIT_JIT=0``.

    ``options``: more command-line arguments for ``script``.
    """
    command = [sys.executable, script, '--plain', '--repeats', str(repeats), *(options or [])]
    environment = {**os.environ, 'EXODIGIT_JIT': '0'}
    done = subprocess.run(command, env=environment, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.stderr.write(done.stderr)
        raise SystemExit(f'the plain-Python subprocess failed (exit {done.returncode})')
    result = json.loads(done.stdout.strip().splitlines()[-1])
    if result['jit']:
        raise SystemExit('the plain-Python subprocess ran compiled: EXODIGIT_JIT=0 was ignored')
    return result
