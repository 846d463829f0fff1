"""A fresh clone is self-contained: its README, docs, configs, sources and every command's
--help point at nothing outside the repository, and every relative link in the docs resolves."""
from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from runtime_helpers import ROOT

# what a path outside the repository looks like in this project's history
# (written with [x] classes so that this line does not match itself)
OUTSIDE = re.compile(r"\.\./shar[e]d|shar[e]d/(?:seeds|spec)|DESIG[N](?:\.md| ?§|:)|\bspe[c]/|\bseed[s]/|spe[c] §|/wor[k]/")
LINK = re.compile(r"\[[^\]]*\]\(([^)#\s]+)(?:#[^)]*)?\)")


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: nothing to clone")
    target = tmp_path_factory.mktemp("clone") / "rtctl"
    subprocess.run(["git", "clone", "-q", "--no-hardlinks", str(ROOT), str(target)], check=True, timeout=120)
    return target


def shipped_text_files(root: Path):
    listed = subprocess.run(["git", "ls-files"], cwd=root, capture_output=True, text=True, check=True).stdout.split()
    for name in listed:
        if name.startswith(("tests/", ".ci/")) or not name.endswith((".md", ".py", ".toml", ".dbc", ".urdf")):
            continue
        yield root / name


def test_no_shipped_file_points_outside_the_repository(clone):
    files = list(shipped_text_files(clone))
    assert clone / "README.md" in files and clone / "docs" / "index.md" in files
    hits = [f"{path.relative_to(clone)}:{n}: {line.strip()}"
            for path in files for n, line in enumerate(path.read_text().splitlines(), 1) if OUTSIDE.search(line)]
    assert not hits, "\n".join(hits)


def test_every_relative_link_in_the_docs_resolves(clone):
    missing = []
    for page in [clone / "README.md", *sorted((clone / "docs").glob("*.md"))]:
        for line in page.read_text().splitlines():
            for target in LINK.findall(line):
                if "://" in target:
                    continue
                if not (page.parent / target).resolve().is_relative_to(clone):
                    missing.append(f"{page.name}: {target} (outside the repository)")
                elif not (page.parent / target).exists():
                    missing.append(f"{page.name}: {target}")
    assert not missing, missing


def test_every_help_stays_inside_the_repository(clone):
    from rtctl.cli import _parser

    subcommands = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction)).choices
    assert {"run", "check", "export"} <= set(subcommands)
    env = {**os.environ, "PYTHONPATH": str(clone)}  # the clone's code, not this tree's
    commands = [["rtctl.cli", "--help"], *(["rtctl.cli", sub, "--help"] for sub in subcommands),
                ["hil_sim.cli", "--help"]]
    for args in commands:
        result = subprocess.run([sys.executable, "-m", *args], cwd=clone, env=env, capture_output=True, text=True,
                                timeout=60)
        assert result.returncode == 0, (args, result.stderr)
        assert len(result.stdout) > 100, args
        hits = [line for line in result.stdout.splitlines() if OUTSIDE.search(line) or "../" in line]
        assert not hits, (args, hits)
