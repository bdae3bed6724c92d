#!/usr/bin/python3
"""Checks a headless rviz screenshot: not black or empty, and the whole scene in view.

  check_screenshot.py IMAGE.png [--background 40,40,48] [--grid 160,160,164]

The 3-D view is found as the bounding box of the pixels of rviz's background colour. The scene
is every pixel inside it that is neither background nor grid (nor a blend of the two: the grid
is drawn half transparent and anti-aliased). The check fails (exit 1, saying why) if the view is
missing, if the scene covers under 0.1 % of the view, or if it touches the view's edge (then the
camera cut part of it off). Prints the scene's extent as fractions of the view.
Reads the PNG with matplotlib (Debian's python3-matplotlib).
"""
import argparse
import sys

import numpy as np
from matplotlib import image as mpimg

MIN_SCENE_SHARE = 0.001  # of the view's pixels (a thin chain covers a few thousand)
EDGE_MARGIN = 2          # pixels the scene keeps from the view's edge
BLEND_DISTANCE = 30.0    # colour distance from the background-grid blend line still counted as it


def colour(text):
    values = [float(v) for v in text.split(",")]
    if len(values) != 3:
        raise argparse.ArgumentTypeError("expected R,G,B")
    return np.array(values)


def check(path, background, grid):
    pixels = mpimg.imread(path)
    if pixels.dtype != np.uint8:
        pixels = np.round(pixels * 255.0)
    if pixels.ndim == 2:  # a grey image (an rviz window not drawn yet): grey as R = G = B
        pixels = np.stack([pixels] * 3, axis=2)
    rgb = pixels[:, :, :3].astype(float)
    is_background = np.all(np.abs(rgb - background) <= 3.0, axis=2)
    if not is_background.any():
        return False, "no pixel of the background colour %s: no 3-D view" % background.tolist()
    rows = np.flatnonzero(is_background.any(axis=1))
    cols = np.flatnonzero(is_background.any(axis=0))
    top, bottom, left, right = rows[0], rows[-1], cols[0], cols[-1]
    view = rgb[top:bottom + 1, left:right + 1]
    # distance of each pixel from the segment background -> grid colour
    axis = grid - background
    t = np.clip(((view - background) @ axis) / (axis @ axis), 0.0, 1.0)
    nearest = background + t[:, :, None] * axis
    scene = np.linalg.norm(view - nearest, axis=2) > BLEND_DISTANCE
    share = scene.mean()
    height, width = scene.shape
    if share < MIN_SCENE_SHARE:
        return False, ("the scene covers %.2f %% of the %dx%d view (under %.1f %%): black or empty"
                       % (100 * share, width, height, 100 * MIN_SCENE_SHARE))
    srows = np.flatnonzero(scene.any(axis=1))
    scols = np.flatnonzero(scene.any(axis=0))
    extent = (scols[0] / width, (scols[-1] + 1) / width, srows[0] / height, (srows[-1] + 1) / height)
    touches = [name for name, edge in (("left", scols[0] < EDGE_MARGIN),
                                       ("right", scols[-1] >= width - EDGE_MARGIN),
                                       ("top", srows[0] < EDGE_MARGIN),
                                       ("bottom", srows[-1] >= height - EDGE_MARGIN)) if edge]
    summary = ("scene covers %.1f %% of the %dx%d view, x %.2f-%.2f, y %.2f-%.2f of it"
               % ((100 * share, width, height) + extent))
    if touches:
        return False, summary + "; it touches the view's %s edge: cut off" % ", ".join(touches)
    return True, summary


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("image")
    parser.add_argument("--background", type=colour, default=colour("40,40,48"))
    parser.add_argument("--grid", type=colour, default=colour("160,160,164"))
    args = parser.parse_args()
    ok, message = check(args.image, args.background, args.grid)
    print("%s: %s" % (args.image, message))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
