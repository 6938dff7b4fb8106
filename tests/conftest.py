"""Shared test setup.

Importing :mod:`pgcomm` enables JAX x64 (float64 everywhere); the assertion makes
a silent float32 fallback fail loudly instead of loosening every tolerance.

JAX's dtype promotion is made strict, so an accidental mix of dtypes in the package
raises instead of silently promoting.
"""

from __future__ import annotations

import os

# The tests run the command line in-process (pgcomm.cli.main), so they set what the `pgcomm` program sets before
# NumPy loads (pgcomm.cli): one BLAS thread, as in the fleet's workers, so that in-process and worker results are
# summed in the same order.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("JAX_PLATFORMS", "cpu")
# two malloc arenas per process, as the fleet's workers have (WORKER_ENV): the xdist workers and the Dask workers
# they start inherit it (glibc reads it at a process's start); ~40 MB less per process
os.environ.setdefault("MALLOC_ARENA_MAX", "2")


def _worker_compile_cache() -> None:
    """Under pytest-xdist, each worker process gets its own folder of JAX's persistent compilation cache.

    JAX writes a cache entry in place (no rename): a worker reading an entry the other worker is still writing
    gets a warning, which this suite turns into an error. A folder per worker (``<cache>/pytest-gw0``, ...) has
    one writer; an explicit ``$PGCOMM_COMPILE_CACHE`` or ``$JAX_COMPILATION_CACHE_DIR`` is left as it is.
    """
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    if not worker or "PGCOMM_COMPILE_CACHE" in os.environ or os.environ.get("JAX_COMPILATION_CACHE_DIR"):
        return
    from pgcomm.cli import compile_cache_dir

    os.environ["PGCOMM_COMPILE_CACHE"] = os.path.join(compile_cache_dir(), f"pytest-{worker}")


_worker_compile_cache()

import jax  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pgcomm.models  # noqa: F401, E402  (a computing module: enables x64 at import)
from pgcomm._memory import release_compiled_programs, trim_heap  # noqa: E402

assert jax.config.jax_enable_x64, "pgcomm's computing modules must enable JAX x64 at import"
jax.config.update("jax_numpy_dtype_promotion", "strict")


@pytest.fixture
def rng():
    """A seeded NumPy generator (explicit seeds only)."""
    return np.random.default_rng(20240611)


@pytest.fixture(scope="session")
def cc():
    """Path of the system C compiler; the tests that compile exported C are skipped only if there is none."""
    import shutil

    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return path
    pytest.skip("no C compiler (cc, gcc, clang) on PATH")


def _release_memory() -> None:
    """Drop JAX's in-memory caches of traced and compiled programs and hand the freed heap back to the system.

    JAX keeps every compiled program for the life of the process, and glibc keeps freed heap for reuse: a test
    module that runs whole commands (``reproduce --quick`` peaks at ~1.5 GB) would leave its process that large
    for every module after it, and the suite grew to over 5 GB. Programs needed again are compiled again (or
    loaded from the persistent compilation cache once a command has enabled it, see
    pgcomm.cli.compile_cache_dir); the compiled code, and so every number, is the same.
    """
    release_compiled_programs()


@pytest.fixture(scope="session")
def release_memory():
    """:func:`_release_memory`, for a fixture that runs several whole commands in a row."""
    return _release_memory


@pytest.fixture(autouse=True, scope="module")
def _release_memory_after_module():
    yield
    _release_memory()


@pytest.fixture(autouse=True)
def _trim_heap_after_test():
    """After each test, the heap its compilations freed (the compiled programs stay for the module's next tests):
    the next test's peak then starts from what the process holds, not from the last test's high-water mark."""
    yield
    trim_heap()


# ----------------------------------------------------------------------------------------- running in parallel
# pyproject.toml runs the suite on pytest-xdist workers (-n auto --dist loadfile): a test file runs whole on one
# worker, so its module fixtures are computed once. Each worker is one process with its own JAX programs and
# arrays, so the number of workers is what bounds the suite's memory.

#: at most this many worker processes, whatever the machine's core count ($PYTEST_XDIST_AUTO_NUM_WORKERS overrides)
MAX_WORKERS = 2

#: the test files that run whole commands end to end (marked ``slow``): ``reproduce --quick`` peaks at ~1.2 GB, the
#: fleet runs two worker processes of its own (~1.8 GB with the test's), and the interrupt tests of
#: ``test_bad_input.py`` run ``pgcomm reproduce`` as subprocesses, so these run one after the other on one xdist
#: worker (the fleet beside the subprocesses took the suite to 3.1 GB), as one work unit that starts first, while
#: the other worker takes the rest file by file
END_TO_END = ("test_bad_input.py", "test_fleet.py", "test_readme_rig.py", "test_reproduce.py", "test_zoo_pipeline.py")


#: the other files whose tests run whole commands in-process and reach ~0.9-1.2 GB: never two at once
#: (:func:`_one_heavy_file_at_a_time`), spread through the second half of the light files (:func:`_file_rank`)
HEAVY = ("test_cli.py", "test_export_lut.py", "test_export_spline.py", "test_extensions.py", "test_identify.py",
         "test_safe_law.py", "test_sensorless.py", "test_docs.py", "test_cli_export.py")


#: test files that run with the other xdist worker paused between two of its tests: the fleet's two Dask worker
#: processes beside its own worker are the suite's largest moment (~2.1 GB), and a light file's subprocess beside
#: them took a clean-clone run to 2.97 GiB
ALONE = ("test_fleet.py",)
_lock_files: dict[str, object] = {}
#: the environment variable naming the folder of the run's lock files: the controller makes it before the workers
#: start (they inherit it) and removes it once they have ended, so no run leaves lock files in the temp folder
LOCK_FOLDER = "PGCOMM_TEST_LOCK_FOLDER"


def pytest_configure(config):
    import tempfile

    if not hasattr(config, "workerinput") and LOCK_FOLDER not in os.environ:
        os.environ[LOCK_FOLDER] = tempfile.mkdtemp(prefix="pgcomm-tests-")
        config._pgcomm_lock_folder = os.environ[LOCK_FOLDER]


def pytest_unconfigure(config):
    import shutil

    folder = getattr(config, "_pgcomm_lock_folder", None)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)
        os.environ.pop(LOCK_FOLDER, None)


def _lock(kind: str, mode: int) -> None:
    import fcntl
    import tempfile

    if kind not in _lock_files:
        uid = os.environ["PYTEST_XDIST_TESTRUNUID"]
        folder = os.environ.get(LOCK_FOLDER) or tempfile.gettempdir()
        _lock_files[kind] = open(os.path.join(folder, f"pgcomm-tests-{uid}.{kind}"), "a")
    fcntl.flock(_lock_files[kind], mode)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Under xdist, every test holds a shared lock on one file per run and an :data:`ALONE` test an exclusive
    one, so nothing else runs beside it; the lock is released between tests, so the other worker waits for one
    test at most.

    Linux's flock lets new shared holders in while an exclusive request waits, so the two workers' back-to-back
    shared locks could keep an ALONE test waiting for the other worker's whole queue: a turnstile (a second lock
    the ALONE test holds exclusively while it waits and runs, and every other test passes through shared before
    taking its own lock) stops new tests from starting once an ALONE test is waiting.
    """
    import fcntl

    if not os.environ.get("PYTEST_XDIST_TESTRUNUID"):
        yield
        return
    _one_heavy_file_at_a_time(item)
    alone = item.path.name in ALONE
    if alone:
        _lock("gate", fcntl.LOCK_EX)
        _lock("lock", fcntl.LOCK_EX)
    else:
        _lock("gate", fcntl.LOCK_SH)
        _lock("gate", fcntl.LOCK_UN)
        _lock("lock", fcntl.LOCK_SH)
    try:
        yield
    finally:
        _lock("lock", fcntl.LOCK_UN)
        if alone:
            _lock("gate", fcntl.LOCK_UN)
        # the file's last test (or the last this worker has been handed so far): its module is torn down
        if _heavy_file and (nextitem is None or nextitem.path != item.path):
            _lock("heavy", fcntl.LOCK_UN)
            _heavy_file.clear()


_heavy_file: list = []


def _one_heavy_file_at_a_time(item) -> None:
    """A :data:`HEAVY` file holds an exclusive lock from its first test to its last (released in
    :func:`pytest_runtest_protocol` once the module is torn down and its memory handed back), so two of them never
    run side by side: each alone reaches 0.7-1.25 GB (test_identify.py the most), and two at once at the suite's
    end took a clean-clone run to 2.79 GiB of 3 GB. A worker waits for it holding no other lock, so it cannot
    deadlock with the ALONE turnstile."""
    import fcntl

    if item.path.name in HEAVY and not _heavy_file:
        _lock("heavy", fcntl.LOCK_EX)
        _heavy_file.append(item.path)


def pytest_xdist_auto_num_workers(config):
    env = os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS")
    if env:
        return int(env)
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count() or 1
    return max(1, min(MAX_WORKERS, cores))


def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` with the :data:`END_TO_END` files as one unit (xdist's ``loadgroup`` marks cannot do
    it here: xdist 3.8 renames the test ids through an attribute pytest 9 no longer reads)."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class EndToEndTogether(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            path = nodeid.split("::", 1)[0]
            return "end-to-end" if os.path.basename(path) in END_TO_END else path

    return EndToEndTogether(config, log)


@pytest.hookimpl(tryfirst=True)  # the marks before -m selects on them
def pytest_collection_modifyitems(config, items):
    """The :data:`END_TO_END` files are ``slow`` and come first (a stable sort; xdist's work units follow the
    collection's order), so that the suite does not end on them, the fleet first among them; the :data:`HEAVY`
    files are spread evenly through the second half of the other files."""
    for item in items:
        if item.path.name in END_TO_END:
            item.add_marker(pytest.mark.slow)
    names = sorted({item.path.name for item in items})
    items.sort(key=lambda item: _file_rank(item.path.name, names))


def _file_rank(name: str, names: list) -> tuple:
    """A file's place in the run: the fleet, the other end-to-end files, then the rest, where each :data:`HEAVY` file
    follows a stretch of light ones. The heavy files hold a lock from their first test to their last, so two of them
    side by side stop a worker: all of them at the end left one worker idle for a minute (the lock serialised ~150 s
    of tests). They stay in the second half, so that the other worker is on light files while the end-to-end unit
    starts with the fleet (~1.8 GB with its two worker processes) and meets them only beside ``test_reproduce.py`` or
    later (a run with them beside the fleet peaked at 2.82 GiB)."""
    if name in END_TO_END:
        return (0, name != "test_fleet.py", 0.0)
    light = [n for n in names if n not in END_TO_END and n not in HEAVY]
    heavy = [n for n in names if n in HEAVY]
    if name in heavy:
        # the k-th heavy file sits after the light file at position half + (k + 1/2) * (half / len(heavy))
        half = len(light) / 2
        return (1, False, half + (heavy.index(name) + 0.5) * half / len(heavy))
    return (1, False, float(light.index(name)))
