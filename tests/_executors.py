"""Executors for tests that must not run the finite-element model."""

from skin_indent.runtime.executors import Executor


class FakeExecutor(Executor):
    """Answers every run at once with a smooth positive curve (no finite elements); counts the runs."""

    def __init__(self):
        self.runs = 0

    def imap_unordered(self, fn, tasks):
        for tag, (_curve, nu, depth) in tasks:
            self.runs += 1
            yield tag, {"values": depth**1.5 * (1 + nu), "reason": None, "seconds": 0.0, "worker": "fake",
                        "code": "x"}, None


class RefusingExecutor(Executor):
    """Fails the test at the first run asked for."""

    def imap_unordered(self, fn, tasks):
        raise AssertionError("a run was asked for")
