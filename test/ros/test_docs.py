#!/usr/bin/python3
"""README.md and docs/ link to files and headings that exist (docs.test)."""
import os
import pathlib
import sys
import tempfile
import unittest

import rostest

ROOT = pathlib.Path(__file__).resolve().parent.parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
import check_docs  # noqa: E402


class DocsTest(unittest.TestCase):
    def test_every_link_resolves(self):
        self.assertEqual(check_docs.problems(ROOT), [])

    def test_broken_links_are_found(self):
        with tempfile.TemporaryDirectory() as tree:
            tree = pathlib.Path(tree)
            (tree / "docs").mkdir()
            (tree / "README.md").write_text(
                "# Title\n\nSee [node](docs/node.md#topics), [gone](docs/gone.md), "
                "[here](#title) and `[code](docs/none.md)`.\n")
            (tree / "docs" / "node.md").write_text(
                "# Node\n\n## Services\n\nBack to [README](../README.md#no-such-heading).\n"
                "```\n## Topics\n```\n")
            found = check_docs.problems(tree)
        self.assertEqual(sorted(found), [
            "README.md: link to docs/gone.md: no such file",
            "README.md: link to docs/node.md#topics: no heading with that anchor",
            "docs/node.md: link to ../README.md#no-such-heading: no heading with that anchor",
        ])

    def test_anchors_follow_githubs_slugs(self):
        self.assertEqual(check_docs.anchors("## Node: simulator_node\n### Time: stamps and /clock\n"
                                            "## Step checks\n## Step checks\n"),
                         {"node-simulator_node", "time-stamps-and-clock", "step-checks",
                          "step-checks-1"})


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "docs", DocsTest)
