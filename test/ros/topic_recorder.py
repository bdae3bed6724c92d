"""A topic's messages with their wall-clock arrival times, for the rostests' polled waits."""
import math
import threading
import time

import rospy


class Recorder:
    """Keeps the last `keep` messages of a topic, each with its time.monotonic() arrival."""

    def __init__(self, topic, kind, keep=2000, queue_size=200):
        self.lock = threading.Lock()
        self.items = []
        self.keep = keep
        self.subscriber = rospy.Subscriber(topic, kind, self, queue_size=queue_size)

    def __call__(self, message):
        with self.lock:
            self.items.append((time.monotonic(), message))
            del self.items[:-self.keep]

    def since(self, start, end=math.inf):
        """The messages that arrived in [start, end] (wall, time.monotonic())."""
        with self.lock:
            return [m for t, m in self.items if start <= t <= end]

    def latest(self):
        with self.lock:
            return self.items[-1][1] if self.items else None


def diagnostic_value(recorder, since, key_prefix):
    """The newest value, among the /diagnostics arrays `recorder` took since `since` (wall,
    time.monotonic()), whose key starts with `key_prefix`; None if there is none."""
    for array in reversed(recorder.since(since)):
        for status in array.status:
            for kv in status.values:
                if kv.key.startswith(key_prefix):
                    return kv.value
    return None


def publish_for(publisher, make, seconds, rate=30.0, bad=()):
    """Publishes make() on `publisher` at `rate` [Hz] for `seconds` of wall time, and each
    message of `bad` once, halfway (the holder tests' stream with bad input in it)."""
    end = time.monotonic() + seconds
    sent_bad = False
    while time.monotonic() < end:
        publisher.publish(make())
        if not sent_bad and time.monotonic() > end - seconds / 2:
            for message in bad:
                publisher.publish(message)
            sent_bad = True
        time.sleep(1.0 / rate)
