"""Every ```python block of README.md runs as written and alone, each in a fresh interpreter (a reader copies one
block, not the page: none may lean on names from another), in a temporary directory with no models/ folder (the
bundled models load by name, as where vibdyn is installed); the README stays a first visit's page (at most
12 000 characters) whose links and picture exist. The material that moved out of it is in docs/, whose code
tests/test_docs.py runs. The blocks run again in a fresh venv holding the base install alone (.ci/wheel-check,
through :func:`blocks` run as a script)."""

import fnmatch
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]  # (conftest's, not imported from it: the script needs no pytest)
README = ROOT / "README.md"
BLOCK = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)


def blocks():
    """(line number, source) of every ```python block of README.md."""
    text = README.read_text(encoding="utf-8")
    return [(text[:m.start(1)].count("\n") + 1, m.group(1)) for m in BLOCK.finditer(text)]


#: run in each fresh interpreter: the block (read from stdin) off screen (matplotlib's Agg), compiled with its README
#: line numbers so that a traceback points into README.md
_ALONE = """
import sys
import matplotlib
matplotlib.use("Agg")
line, path = int(sys.argv[1]), sys.argv[2]
exec(compile("\\n" * (line - 1) + sys.stdin.read(), path, "exec"), {"__name__": "__main__"})
"""


def run_blocks():
    """Run every block of :func:`blocks` alone, each in a fresh interpreter (this one's Python) in the current
    directory; a failure names the block's README line and ends with its traceback. Returns the number of
    blocks."""
    import os
    import subprocess

    env = {**os.environ, "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")}
    for line, source in blocks():
        run = subprocess.run([sys.executable, "-c", _ALONE, str(line), str(README)], input=source, text=True,
                             capture_output=True, env=env, timeout=600)
        if run.returncode:
            raise AssertionError(f"README.md block at line {line}, run alone in a fresh interpreter, failed:\n"
                                 f"{run.stderr[-3000:]}")
    return len(blocks())


def test_readme_has_python_blocks():
    assert len(blocks()) >= 1  # the first example
    assert all("assert " in source for _, source in blocks())  # each checks what it shows


def test_readme_is_short_and_its_links_exist():
    text = README.read_text(encoding="utf-8")
    assert len(text) <= 12_000, f"README.md has {len(text)} characters: move the details into docs/"
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if not re.match(r"\w+://", t)]
    assert "docs/_static/readme-modes.png" in local and "docs/getting-started.md" in local
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


def test_readme_blocks_run_each_alone(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no models/ folder here: the README loads the bundled models by name, as installed
    assert run_blocks() == len(blocks())
    # what the tour wrote is covered by .gitignore (simple glob lines there), so it never lands in a commit
    ignored = [line.strip() for line in (ROOT / ".gitignore").read_text().splitlines()
               if line.strip() and not line.startswith(("#", "!"))]
    written = [p.name for p in tmp_path.iterdir()]
    assert written, "the tour writes files (a01.csv, bode.png, ...): were they moved?"
    uncovered = [name for name in written if not any(fnmatch.fnmatch(name, g.rstrip("/")) for g in ignored)]
    assert not uncovered, f"README examples write files .gitignore does not cover: {uncovered}"


if __name__ == "__main__":  # .ci/wheel-check: python tests/test_readme.py, from a folder outside the checkout
    import vibdyn

    print(f"README.md: {run_blocks()} python blocks ran with vibdyn {vibdyn.__version__} from "
          f"{Path(vibdyn.__file__).parent}", file=sys.stderr)
