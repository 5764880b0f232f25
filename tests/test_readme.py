"""The README stays a front page: at most 150 lines, with the two commands (the demo render and
the test command ``.ci/run`` runs, verbatim), the picture, the command-line tour, and links that
point at files which exist."""
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
MAX_LINES = 150
TEST_COMMAND = ("pip install torch==2.13.0 -e '.[learned,dev,gui,bench,reference]' && "
                "python -m pytest -n 2 --dist loadfile")


def test_readme_is_at_most_150_lines():
    n = len(README.splitlines())
    assert n <= MAX_LINES, f"README.md has {n} lines; move detail to docs/"


def test_readme_keeps_the_two_commands():
    assert "pip install -e . && relight render --out demo.png" in README
    assert TEST_COMMAND in README


def test_ci_runs_the_readme_test_command():
    assert TEST_COMMAND in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_readme_keeps_the_picture_and_the_tour():
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README)
    assert "assets/docs/gallery/hero.png" in pictures
    assert "## A tour of the command line" in README
    tour = README.split("## A tour of the command line", 1)[1].split("\n## ", 1)[0]
    for command in ("render", "view", "scene", "reference", "parity", "info", "graph", "bench",
                    "gallery", "decompose", "train", "data", "eval"):
        assert f"`relight {command}" in tour, command


def test_readme_links_exist():
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README)
    local = [t for t in targets if "://" not in t]
    assert local
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, f"README links to missing files: {missing}"
