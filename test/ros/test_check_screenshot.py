#!/usr/bin/python3
"""scripts/check_screenshot.py decides on made-up pictures as it should (check_screenshot.test)."""
import os
import sys
import tempfile
import unittest

import numpy as np
import rostest
from matplotlib import image as mpimg

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import check_screenshot  # noqa: E402

BACKGROUND = np.array([40.0, 40.0, 48.0])
GRID = np.array([160.0, 160.0, 164.0])


class CheckScreenshotTest(unittest.TestCase):
    def picture(self, draw):
        """A 200 x 320 view of rviz's background with a toolbar above it and a half-transparent
        grid line across it, then `draw(pixels)`; the check's verdict and message."""
        pixels = np.zeros((240, 320, 3), dtype=np.uint8)
        pixels[:40] = (220, 220, 220)  # a toolbar: not part of the view
        pixels[40:] = BACKGROUND
        pixels[120, :] = np.round(0.5 * BACKGROUND + 0.5 * GRID)  # the grid, blended
        draw(pixels)
        with tempfile.NamedTemporaryFile(suffix=".png") as f:
            mpimg.imsave(f.name, pixels)
            return check_screenshot.check(f.name, BACKGROUND, GRID)

    def test_black_fails(self):
        ok, message = self.picture(lambda p: p.fill(0))
        self.assertFalse(ok)
        self.assertIn("no 3-D view", message)

    def test_background_and_grid_alone_fail(self):
        ok, message = self.picture(lambda p: None)
        self.assertFalse(ok)
        self.assertIn("empty", message)

    def test_a_scene_cut_off_at_an_edge_fails(self):
        def draw(p):
            p[100:140, 280:320] = (255, 80, 0)
        ok, message = self.picture(draw)
        self.assertFalse(ok)
        self.assertIn("right edge", message)

    def test_a_scene_inside_the_view_passes(self):
        def draw(p):
            p[90:150, 100:200] = (255, 80, 0)
        ok, message = self.picture(draw)
        self.assertTrue(ok, message)
        self.assertIn("x 0.31-0.62, y 0.25-0.55", message)  # columns 100-199, rows 50-109 of the view


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "check_screenshot", CheckScreenshotTest)
