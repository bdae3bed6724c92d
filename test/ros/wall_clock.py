"""Waits for the rostests: polled, under wall-clock deadlines (never sim time, which stands still
while the node is paused), generous because they only bound how long a loaded machine may take."""
import os
import signal
import subprocess
import time


def interrupt(process, timeout=30.0):
    """Stops a node we started as Ctrl-C would (SIGINT), killing it if it has not exited within
    `timeout` seconds of wall time."""
    if process.poll() is None:
        os.kill(process.pid, signal.SIGINT)
        try:
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


class WallClockWaits:
    """unittest.TestCase mixin."""

    def wait_until(self, predicate, what, timeout=60.0, poll=0.02):
        """Polls `predicate` until it returns something true and returns that; fails naming
        `what` after `timeout` seconds of wall time."""
        deadline = time.monotonic() + timeout
        while True:
            result = predicate()
            if result:
                return result
            if time.monotonic() >= deadline:
                self.fail(f"{what}: not within {timeout} s (wall)")
            time.sleep(poll)
