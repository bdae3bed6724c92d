"""Counts test cases in catkin's JUnit XML results and prints 'N passed, M failed'.

gtest and rostest both write one <testcase> per test; catkin writes a failing result when a
test binary produced no file. Exits 1 if any test failed or none ran.
"""
import pathlib
import sys
import xml.etree.ElementTree as ElementTree


def main(results_dir):
    passed, failed, skipped = 0, 0, 0
    failures = []
    files = sorted(pathlib.Path(results_dir).rglob("*.xml"))
    for path in files:
        runner = path.name.startswith("rostest-")
        try:
            root = ElementTree.parse(path).getroot()
        except ElementTree.ParseError as error:
            failed += 1
            failures.append(f"{path.name}: unreadable result ({error})")
            continue
        cases = list(root.iter("testcase"))
        failed_before = failed
        for case in cases:
            name = f"{case.get('classname')}.{case.get('name')}"
            # rostest's runner adds one case per test node; rosunit-<test>.xml holds the real
            # cases, so the runner's counts only when that file is missing (a crashed test)
            test_name = (case.get("name") or "")[len("test"):]
            if runner and (path.parent / f"rosunit-{test_name}.xml").exists():
                continue
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
                failures.append(name)
            elif case.find("skipped") is not None or case.get("status") == "notrun":
                skipped += 1
            else:
                passed += 1
        # a suite can count failures no test case shows (unittest subTest in rosunit's XML):
        # trust the larger number
        suites = [root] if root.tag == "testsuite" else list(root.iter("testsuite"))
        declared = sum(int(s.get("failures", "0") or 0) + int(s.get("errors", "0") or 0)
                       for s in suites)
        if root.tag == "testsuites" and not suites:
            declared = int(root.get("failures", "0") or 0) + int(root.get("errors", "0") or 0)
        hidden = declared - (failed - failed_before)
        if hidden > 0 and not (runner and any(
                (path.parent / f"rosunit-{(c.get('name') or '')[len('test'):]}.xml").exists()
                for c in cases)):
            failed += hidden
            failures.append(f"{path.name}: {hidden} failure(s) recorded outside any test case")
    for name in failures:
        print(f"FAILED: {name}")
    print(f"{len(files)} result files in {results_dir}")
    if passed + failed == 0:
        print("no test results found")
        failed = 1
    summary = f"{passed} passed, {failed} failed"
    if skipped:
        summary += f", {skipped} skipped"
    print(summary)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "build/ws/build/test_results"))
