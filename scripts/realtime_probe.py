#!/usr/bin/python3
"""Listens to /simulator/state for a while and reports how well the node kept real time.

Usage: realtime_probe.py LABEL SECONDS PUBLISH_RATE
Prints one line: achieved real-time factor (sim seconds per wall second over the window),
publish interval statistics against 1/PUBLISH_RATE (median, standard deviation, 99th percentile,
maximum) and how often the node said it was behind.
"""
import statistics
import sys
import time

import rospy
from constrained_particles.msg import SimState


def main(label, seconds, publish_rate):
    rospy.init_node("realtime_probe", anonymous=True)
    samples = []
    rospy.Subscriber("/simulator/state", SimState,
                     lambda m: samples.append((time.monotonic(), m.sim_time, m.behind,
                                               m.real_time_factor)), queue_size=100)
    # let it settle, then measure
    time.sleep(3.0)
    samples.clear()
    time.sleep(seconds)
    if len(samples) < 10:
        print(f"{label}: only {len(samples)} messages")
        return 1
    (w0, s0, _, _), (w1, s1, _, _) = samples[0], samples[-1]
    achieved = (s1 - s0) / (w1 - w0)
    intervals = sorted(b[0] - a[0] for a, b in zip(samples, samples[1:]))
    p99 = intervals[min(len(intervals) - 1, int(0.99 * len(intervals)))]
    behind = sum(1 for s in samples if s[2]) / len(samples)
    reported = statistics.median(s[3] for s in samples)
    print(f"{label}: achieved real-time factor {achieved:.3f} (node reports {reported:.3f}), "
          f"behind in {100 * behind:.0f}% of messages; publish interval "
          f"median {1e3 * statistics.median(intervals):.1f} ms, "
          f"std {1e3 * statistics.pstdev(intervals):.2f} ms, p99 {1e3 * p99:.1f} ms, "
          f"max {1e3 * intervals[-1]:.1f} ms (target {1e3 / publish_rate:.1f} ms), "
          f"{len(samples)} messages in {w1 - w0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], float(sys.argv[2]), float(sys.argv[3])))
