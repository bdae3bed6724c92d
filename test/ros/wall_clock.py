"""Waits for the rostests: polled, under wall-clock deadlines (never sim time, which stands still
while the node is paused), generous because they only bound how long a loaded machine may take."""
import time


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
