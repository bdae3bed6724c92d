#!/usr/bin/python3
"""README.md and docs/ link to files and headings that exist, name no commit outside a generated
block, and their generated blocks are what docs/bench/ gives now, each from a run (docs.test)."""
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

    def test_a_commit_hash_stands_only_in_a_generated_block(self):
        text = ("Measured at 3f9a2c1 by hand.\n"
                "<!-- generated: cores -->\n_From the run at commit 120ddd2._\n"
                "<!-- end generated -->\n"
                "A number 1234567 and the word accede are no hash; deadbeef0 is one.\n")
        self.assertEqual(list(check_docs.commit_hashes(text)), [(1, "3f9a2c1"), (5, "deadbeef0")])

    def test_every_generated_block_matches_its_files(self):
        import performance_page
        for page in sorted((ROOT / "docs").glob("*.md")):
            text = page.read_text()
            with tempfile.TemporaryDirectory() as tree:
                copy = pathlib.Path(tree) / page.name
                copy.write_text(text)
                filled = performance_page.fill_page(copy, ROOT / "docs" / "bench")
            self.assertEqual(filled, text, f"{page.name}: run scripts/performance_page.py")

    def test_every_generated_block_holds_a_measurement(self):
        # a block whose command never ran says "Not measured yet"; a reliability row "not measured"
        unmeasured = [f"{page.name}: {line.strip()[:100]}"
                      for page in sorted((ROOT / "docs").glob("*.md"))
                      for block in check_docs.GENERATED.findall(page.read_text())
                      for line in block.split("\n") if "not measured yet" in line.lower()]
        self.assertEqual(unmeasured, [], "run the command each names")

    def test_anchors_follow_githubs_slugs(self):
        self.assertEqual(check_docs.anchors("## Node: simulator_node\n### Time: stamps and /clock\n"
                                            "## Step checks\n## Step checks\n"),
                         {"node-simulator_node", "time-stamps-and-clock", "step-checks",
                          "step-checks-1"})


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "docs", DocsTest)
