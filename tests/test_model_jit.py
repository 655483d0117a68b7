"""The kernels' decorator and its cache policy (exodigit_model/kernels/jit.py).

What depends on the process (the JIT switch, numba's configuration, the one warning) runs in a
fresh interpreter with its own environment; a throwaway module in tmp_path holds the kernels, so
the real cache is never touched (NUMBA_CACHE_DIR, HOME and XDG_CACHE_HOME point into tmp_path).
"""

import logging
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest
from exodigit_model.compiling import CompileNotice
from exodigit_model.kernels import jit
from numba.core import event

THROWAWAY = """
from exodigit_model.kernels.jit import kernel


@kernel
def twice_plus_one(x):
    return 2.0 * x + 1.0


@kernel
def inverse(x):
    return 1.0 / x
"""

USER = """
import numba


@numba.njit(cache=True)
def user_function(x):
    return x - 1.0
"""


def run_python(tmp_path: Path, code: str, **environment: str) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter whose imports find tmp_path/src; check it exits 0."""
    source = tmp_path / 'src'
    source.mkdir(exist_ok=True)
    (source / 'throwaway_kernels.py').write_text(THROWAWAY)
    (source / 'user_functions.py').write_text(USER)
    env = {
        key: value
        for key, value in os.environ.items()
        if key not in {'EXODIGIT_JIT', 'NUMBA_CACHE_DIR', 'PYTHONWARNINGS'}
    }
    env.update(
        HOME=str(tmp_path / 'home'),
        XDG_CACHE_HOME=str(tmp_path / 'xdg'),
        ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
        ROS_DOMAIN_ID='57',
    )
    env.update(environment)
    prelude = f'import sys\nsys.path.insert(0, {str(source)!r})\n'
    result = subprocess.run(
        [sys.executable, '-W', 'always::RuntimeWarning', '-c', prelude + textwrap.dedent(code)],
        env=env,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    return result


def cache_files(root: Path) -> list[Path]:
    return sorted(path for pattern in ('*.nbi', '*.nbc') for path in root.rglob(pattern))


@pytest.mark.parametrize(('value', 'compiled'), [('0', False), ('1', True), ('false', True)])
def test_only_exodigit_jit_0_turns_the_compiler_off(tmp_path, value, compiled):
    """EXODIGIT_JIT=0, and only it, makes ``kernel`` the identity; then the plain path raises
    on a division by zero where the compiled one gives inf (one interpreter per value)."""
    result = run_python(
        tmp_path,
        """
        from exodigit_model.kernels import jit
        from throwaway_kernels import inverse

        def f(x):
            return x
        print(jit.JIT, jit.kernel(f) is f)
        try:
            print(inverse(0.0))
        except ZeroDivisionError:
            print('ZeroDivisionError')
        """,
        EXODIGIT_JIT=value,
        NUMBA_CACHE_DIR=str(tmp_path / 'cache'),
    )
    division = 'inf' if compiled else 'ZeroDivisionError'
    assert result.stdout.split() == [str(compiled), str(not compiled), division]


def test_kernels_are_cached_under_the_digest_of_the_kernel_sources_and_loaded_again(tmp_path):
    """The first interpreter compiles and caches under exodigit-<digest>, the second loads it
    from there; in the second, a user's own ``numba.njit(cache=True)`` function caches where it
    would have without us (numba.config.CACHE_DIR unchanged, no exodigit- directory)."""
    cache = tmp_path / 'cache'
    code = """
    from throwaway_kernels import twice_plus_one
    print(twice_plus_one(3.0), sum(twice_plus_one.stats.cache_hits.values()))
    """
    first = run_python(tmp_path, code, NUMBA_CACHE_DIR=str(cache))
    assert first.stdout.split() == ['7.0', '0']
    ours = cache / f'exodigit-{jit.source_digest()}'
    files = cache_files(cache)
    assert {path.suffix for path in files} == {'.nbi', '.nbc'}
    assert all(path.is_relative_to(ours) for path in files), files
    assert 'cannot be cached' not in first.stderr
    second = run_python(
        tmp_path,
        """
        import numba
        before = numba.config.CACHE_DIR
        from throwaway_kernels import twice_plus_one
        from user_functions import user_function
        print(twice_plus_one(3.0), sum(twice_plus_one.stats.cache_hits.values()))
        print(numba.config.CACHE_DIR == before, user_function(3.0))
        print(twice_plus_one.stats.cache_path)
        print(user_function.stats.cache_path)
        """,
        NUMBA_CACHE_DIR=str(cache),
    )
    value, hits, unchanged, user_value, path, theirs = second.stdout.split()
    assert (value, hits) == ('7.0', '1')  # loaded from the cache, not compiled
    assert (unchanged, user_value) == ('True', '2.0')
    assert Path(path).parent == ours
    assert Path(theirs).parent == cache
    assert not Path(theirs).name.startswith('exodigit-')


def test_a_cold_cache_says_once_that_the_kernels_compile_and_where_a_warm_one_is_silent(
    tmp_path,
):
    """One small kernel of the package (the Yeoh stress), no logging configured: the first
    interpreter warns once on stderr, naming the cache; the second loads it and says nothing.
    The user's own numba functions (a throwaway module) compile without a word."""
    cache = tmp_path / 'cache'
    code = """
    import numpy as np
    from exodigit_model import load_params
    from exodigit_model.physics.material import yeoh_stress
    from throwaway_kernels import twice_plus_one
    from user_functions import user_function
    material = load_params().material
    for _ in range(2):
        yeoh_stress(material, np.linspace(0.9, 1.5, 4))
    print(twice_plus_one(3.0), user_function(3.0))
    """
    cold = run_python(tmp_path, code, NUMBA_CACHE_DIR=str(cache))
    notices = [line for line in cold.stderr.splitlines() if 'compiling' in line]
    assert len(notices) == 1, cold.stderr
    assert f'into {cache / f"exodigit-{jit.source_digest()}"},' in notices[0]
    assert 'about a minute' in notices[0]
    warm = run_python(tmp_path, code, NUMBA_CACHE_DIR=str(cache))
    assert 'compiling' not in warm.stderr, warm.stderr


def inner(x):
    return x + 1.0


def outer(x):
    return 2.0 * compiled_inner(x)


def other(x):
    return x - 1.0


compiled_inner = numba.njit(inner)


def test_the_notice_warns_at_the_first_compile_and_times_each_outermost_one(caplog):
    """Functions of this module stand for the kernels: one warning at the first compile, one
    info line per outermost compile (``outer`` compiles ``inner`` inside it), none when numba
    calls what it compiled; functions of other modules, or of none, are not announced."""
    notice = CompileNotice(package=__name__)
    foreign = numba.njit(lambda x: x * 3.0)
    foreign.py_func.__module__ = 'elsewhere'
    nameless = {}  # a function made by exec has no module
    exec('def nameless(x):\n    return x\n', nameless)
    event.register('numba:compile', notice)
    try:
        with caplog.at_level(logging.INFO, logger='exodigit_model.compiling'):
            foreign(1.0)
            numba.njit(nameless['nameless'])(1.0)
            assert caplog.records == []
            assert numba.njit(outer)(1.0) == 4.0
            numba.njit(other)(1.0)
            numba.njit(other)  # a new dispatcher, never called: nothing compiles
    finally:
        event.unregister('numba:compile', notice)
    said = [(record.levelname, record.getMessage()) for record in caplog.records]
    assert [level for level, _ in said] == ['WARNING', 'INFO', 'INFO'], said
    assert 'numba is compiling the model kernels' in said[0][1]
    assert f'compiled {__name__}.outer in ' in said[1][1]
    assert f'compiled {__name__}.other in ' in said[2][1]


def test_an_unwritable_numba_cache_dir_compiles_in_memory_with_one_warning(tmp_path):
    (tmp_path / 'afile').write_text('a file, so afile/cache cannot be made')
    result = run_python(
        tmp_path,
        """
        from throwaway_kernels import inverse, twice_plus_one
        print(twice_plus_one(3.0), inverse(4.0))
        """,
        NUMBA_CACHE_DIR=str(tmp_path / 'afile' / 'cache'),
    )
    assert result.stdout.split() == ['7.0', '0.25']
    warnings = [line for line in result.stderr.splitlines() if 'RuntimeWarning' in line]
    assert len(warnings) == 1, result.stderr
    assert 'cannot be cached' in warnings[0]
    assert 'in memory' in warnings[0]
    assert 'NUMBA_CACHE_DIR' in warnings[0]
    # The user chose the cache's place: numba's own fallbacks (the module's __pycache__, the
    # user cache under XDG_CACHE_HOME) are not used either.
    assert cache_files(tmp_path) == []


def test_kernels_numba_refuses_to_cache_compile_in_memory_with_one_warning(tmp_path):
    # Functions with no source file: numba finds no cache locator for either of them.
    result = run_python(
        tmp_path,
        """
        from exodigit_model.kernels.jit import kernel
        namespace = {}
        exec('def double(x):\\n    return 2.0 * x\\n', namespace)
        exec('def halve(x):\\n    return 0.5 * x\\n', namespace)
        double, halve = kernel(namespace['double']), kernel(namespace['halve'])
        print(double(3.0), halve(3.0))
        """,
        NUMBA_CACHE_DIR=str(tmp_path / 'cache'),
    )
    assert result.stdout.split() == ['6.0', '1.5']
    warnings = [line for line in result.stderr.splitlines() if 'RuntimeWarning' in line]
    assert len(warnings) == 1, result.stderr
    assert 'cannot cache function' in warnings[0]
    assert cache_files(tmp_path) == []


def test_without_numba_cache_dir_the_package_pycache_comes_first_then_the_user_cache(
    tmp_path, monkeypatch
):
    monkeypatch.setattr(numba.config, 'CACHE_DIR', '')
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg'))
    package = jit.KERNELS_DIR / '__pycache__' / 'numba'
    assert jit.cache_bases() == [package, tmp_path / 'xdg' / 'exodigit']
    monkeypatch.setenv('XDG_CACHE_HOME', 'relative/xdg')  # ignored, as the XDG spec says
    monkeypatch.setenv('HOME', str(tmp_path / 'home'))
    assert jit.cache_bases() == [package, tmp_path / 'home' / '.cache' / 'exodigit']
    monkeypatch.setattr(numba.config, 'CACHE_DIR', str(tmp_path / 'mine'))
    assert jit.cache_bases() == [tmp_path / 'mine']


def test_the_first_writable_base_holds_the_cache(tmp_path, monkeypatch):
    (tmp_path / 'afile').write_text('')
    bases = [tmp_path / 'afile' / 'cache', tmp_path / 'writable']
    monkeypatch.setattr(jit, 'cache_bases', lambda: bases)
    chosen = jit.cache_directory.__wrapped__()
    assert chosen == tmp_path / 'writable' / f'exodigit-{jit.source_digest()}'
    assert chosen.is_dir()


def test_the_digest_follows_every_kernel_source_and_nothing_else(tmp_path):
    for name, text in [('a.py', 'x = 1\n'), ('b.py', 'y = 2\n'), ('notes.txt', 'n\n')]:
        (tmp_path / name).write_text(text)
    digest = jit.source_digest(tmp_path)
    assert len(digest) == 16
    assert int(digest, 16) >= 0
    (tmp_path / 'notes.txt').write_text('changed\n')
    assert jit.source_digest(tmp_path) == digest
    (tmp_path / 'b.py').write_text('y = 3\n')
    assert jit.source_digest(tmp_path) != digest
    (tmp_path / 'b.py').write_text('y = 2\n')
    assert jit.source_digest(tmp_path) == digest
    (tmp_path / 'b.py').rename(tmp_path / 'c.py')
    assert jit.source_digest(tmp_path) != digest


def test_prune_removes_only_the_caches_of_other_digests(tmp_path):
    current = tmp_path / 'exodigit-0123456789abcdef'
    stale = tmp_path / 'exodigit-fedcba9876543210'
    kept = [
        current,
        tmp_path / 'exodigit-notes',  # not a digest
        tmp_path / 'exodigit-0123456789ABCDEF',  # not ours: upper case
        tmp_path / 'numba-things',
    ]
    for directory in [*kept, stale]:
        (directory / 'sub').mkdir(parents=True)
        (directory / 'sub' / 'f.nbi').write_text('')
    (tmp_path / 'exodigit-aaaaaaaaaaaaaaaa').write_text('a file, not a cache directory')
    assert jit.prune(current) == [stale]
    assert not stale.exists()
    assert all((directory / 'sub' / 'f.nbi').is_file() for directory in kept)
    assert (tmp_path / 'exodigit-aaaaaaaaaaaaaaaa').is_file()
