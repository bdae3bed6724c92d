#!/usr/bin/python3
"""simulator_node started before its master waits for it; after a master restart it keeps
running (roscpp does not re-register its topics and services with the new master)."""
import os
import socket
import subprocess
import time
import unittest

import rostest


def free_port():
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


class MasterStartTest(unittest.TestCase):
    def setUp(self):
        self.port = free_port()
        self.env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{self.port}")
        self.processes = []

    def tearDown(self):
        for p in reversed(self.processes):
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()

    def start(self, *command):
        p = subprocess.Popen(list(command), env=self.env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
        self.processes.append(p)
        return p

    def services(self):
        done = subprocess.run(["rosservice", "list"], env=self.env, capture_output=True,
                              text=True, timeout=20)
        return done.stdout.split() if done.returncode == 0 else []

    def wait_for_service(self, name, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if name in self.services():
                return True
            time.sleep(0.5)
        return False

    def test_waits_for_master_then_serves(self):
        node = self.start("rosrun", "constrained_particles", "simulator_node",
                          "__name:=simulator", "_scenario:=bead", "_status_period:=0")
        time.sleep(3.0)
        self.assertIsNone(node.poll(), "the node exited without a master")
        master = self.start("rosmaster", "--core", "-p", str(self.port))
        self.assertTrue(self.wait_for_service("/simulator/reset", 30.0),
                        "the node did not register once the master came up")
        # restart the master: the node keeps running, but is not registered with the new one
        master.terminate()
        master.wait(timeout=10)
        time.sleep(2.0)
        self.start("rosmaster", "--core", "-p", str(self.port))
        time.sleep(5.0)
        self.assertIsNone(node.poll(), "the node exited when the master restarted")
        registered = "/simulator/reset" in self.services()
        print(f"after a master restart the node is {'re-registered' if registered else 'not re-registered'}")
        # documented in README ("Reliability"): restart the node (or launch it with respawn)
        self.assertFalse(registered, "roscpp re-registered: update README's Reliability section")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "master_start", MasterStartTest)
