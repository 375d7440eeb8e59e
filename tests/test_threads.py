"""BLAS thread limits (skin_indent.runtime.threads): one thread per worker process, and in the CLI's process.

On a loaded machine a full BLAS thread pool per process makes small problems fight over
the cores (the contact scan of the Chiaro curve: 5.2 s instead of 0.07 s); see
benchmarks/threads.py for the measurements.
"""

import multiprocessing
import os
import subprocess
import sys

import pytest
import threadpoolctl

from skin_indent.runtime.threads import THREAD_ENV_VARS, configure_threads, limit_threads, main_threads
from skin_indent.response_surface import LocalProcesses
from skin_indent.runtime.executors import available_cpus

TWO_CORES = pytest.mark.skipif(available_cpus() < 2, reason="a default of 1 BLAS thread cannot show a limit")


def blas_threads(info) -> set:
    """The ``num_threads`` of the BLAS libraries in a ``threadpoolctl.threadpool_info()``."""
    threads = {lib["num_threads"] for lib in info if lib["user_api"] == "blas"}
    assert threads, "no BLAS library loaded"
    return threads


def env_and_blas_info() -> tuple:
    """``OPENBLAS_NUM_THREADS`` and ``threadpoolctl.threadpool_info()`` after loading numpy, in a worker."""
    env = os.environ.get("OPENBLAS_NUM_THREADS")
    import numpy  # noqa: F401 - a spawned worker has not loaded it yet

    return env, threadpoolctl.threadpool_info()


def run_in_workers(fn, args, mp_context=None) -> list:
    with LocalProcesses(2, mp_context=mp_context) as ex:
        outcomes = list(ex.imap_unordered(fn, [(i, args) for i in range(4)]))
    assert all(error is None for _, _, error in outcomes), outcomes
    return [value for _, value, _ in outcomes]


@pytest.fixture
def two_threads(monkeypatch):
    """This process with 2 BLAS threads and no thread variables: what workers would inherit."""
    for name in (*THREAD_ENV_VARS, "SKIN_INDENT_THREADS"):
        monkeypatch.delenv(name, raising=False)
    with threadpoolctl.threadpool_limits(limits=2):
        yield


@TWO_CORES
def test_local_workers_run_with_one_blas_thread(two_threads):
    """Forked workers: the initializer limits the BLAS libraries they inherited loaded."""
    for info in run_in_workers(threadpoolctl.threadpool_info, ()):
        assert blas_threads(info) == {1}
    assert blas_threads(threadpoolctl.threadpool_info()) == {2}  # this process got its limit back
    assert "OPENBLAS_NUM_THREADS" not in os.environ


@TWO_CORES
def test_spawned_workers_have_the_limit_before_numpy_loads(two_threads):
    """Spawned workers start with OPENBLAS_NUM_THREADS=1 in their environment."""
    for env, info in run_in_workers(env_and_blas_info, (), multiprocessing.get_context("spawn")):
        assert env == "1" and blas_threads(info) == {1}


@TWO_CORES
def test_this_process_uses_one_thread_while_workers_run(two_threads):
    seen = []
    with LocalProcesses(2) as ex:
        for _ in ex.imap_unordered(abs, [(i, (-i,)) for i in range(3)]):
            seen.append(blas_threads(threadpoolctl.threadpool_info()))
    assert seen == [{1}] * 3
    assert blas_threads(threadpoolctl.threadpool_info()) == {2}


@TWO_CORES
def test_off_leaves_workers_alone(two_threads, monkeypatch):
    monkeypatch.setenv("SKIN_INDENT_THREADS", "off")
    for info in run_in_workers(threadpoolctl.threadpool_info, ()):
        assert blas_threads(info) == {2}


def test_limit_threads_restores(two_threads):
    with limit_threads(1):
        assert blas_threads(threadpoolctl.threadpool_info()) == {1}
    assert blas_threads(threadpoolctl.threadpool_info()) == {min(2, available_cpus())}
    with pytest.raises(ValueError):
        with limit_threads(0):
            pass


def test_main_threads_setting(monkeypatch):
    for name in (*THREAD_ENV_VARS, "SKIN_INDENT_THREADS"):
        monkeypatch.delenv(name, raising=False)
    assert main_threads() == 1
    monkeypatch.setenv("SKIN_INDENT_THREADS", "2")
    assert main_threads() == 2
    monkeypatch.setenv("SKIN_INDENT_THREADS", "off")
    assert main_threads() is None and configure_threads() is None
    monkeypatch.setenv("SKIN_INDENT_THREADS", "many")
    with pytest.raises(ValueError, match="SKIN_INDENT_THREADS"):
        main_threads()
    monkeypatch.delenv("SKIN_INDENT_THREADS")
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")  # the user's own setting is kept
    assert main_threads() is None


@TWO_CORES
def test_configure_threads_before_and_after_blas_loads():
    """What the CLI calls first: numpy's BLAS, loaded, gets the limit; scipy's, loaded later, starts with it."""
    code = ("import numpy; from skin_indent.runtime.threads import configure_threads; n = configure_threads()\n"
            "import scipy.linalg, threadpoolctl\n"
            "info = [i for i in threadpoolctl.threadpool_info() if i['user_api'] == 'blas']\n"
            "print(n, len(info), sorted({i['num_threads'] for i in info}))")
    env = {k: v for k, v in os.environ.items() if k not in (*THREAD_ENV_VARS, "SKIN_INDENT_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env,
                         timeout=60).stdout.strip()
    n, libs, threads = out.split(" ", 2)
    assert (n, threads) == ("1", "[1]"), out
