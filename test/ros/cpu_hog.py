#!/usr/bin/python3
"""A busy loop per core for the length of a rostest, so that rostests whose issue asks for a busy
machine (issue 37: sim time, a remapped /clock, cancels, launch arguments) run beside one in CI.

Usage in a .test file: <node pkg="constrained_particles" type="cpu_hog.py" name="cpu_hog"/>.
~loops (int, default: the number of cores) busy processes; they die with this node (SIGINT,
SIGTERM, or this process dying: PR_SET_PDEATHSIG), so a killed test leaves no loop behind.
"""
import ctypes
import multiprocessing
import os
import signal
import sys

import rospy

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def busy_loop():
    # the loop ends when its parent ends, however the parent ends
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() == 1:
        sys.exit(0)
    while True:
        pass


def main():
    rospy.init_node("cpu_hog")
    loops = int(rospy.get_param("~loops", os.cpu_count() or 1))
    if loops < 0 or loops > 64:
        rospy.logfatal("~loops must be in [0, 64], got %d", loops)
        sys.exit(2)
    workers = [multiprocessing.Process(target=busy_loop, daemon=True) for _ in range(loops)]
    for worker in workers:
        worker.start()
    rospy.loginfo("cpu_hog: %d busy loops (pids %s)", loops, [w.pid for w in workers])
    rospy.spin()
    for worker in workers:
        worker.kill()
        worker.join()


if __name__ == "__main__":
    main()
