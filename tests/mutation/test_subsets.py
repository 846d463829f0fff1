"""Samples and shards of a run's mutants (tests/mutation/subsets.py), and a sharded run's
mutants picked up again by a resume without the shard (run.py)."""
from __future__ import annotations

import argparse
import random

import pytest

from subsets import in_shard, parse_shard

KEYS = [f"rtctl/m{random.Random(i).randrange(40)}.py:core/NumberReplacer:{i}" for i in range(2000)]


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_the_shards_cover_every_mutant_exactly_once_in_near_equal_parts(n):
    owners = [[k for k in range(1, n + 1) if in_shard(key, (k, n))] for key in KEYS]
    assert all(len(o) == 1 for o in owners)
    sizes = [sum(o == [k] for o in owners) for k in range(1, n + 1)]
    assert min(sizes) > 0.8 * len(KEYS) / n and max(sizes) < 1.2 * len(KEYS) / n


@pytest.mark.parametrize("text", ["0/2", "3/2", "1/0", "a/2", "2", "-1/2", ""])
def test_a_shard_is_k_of_n_from_one(text):
    with pytest.raises(argparse.ArgumentTypeError, match="K/N"):
        parse_shard(text)


def test_a_shard_is_read():
    assert parse_shard("2/3") == (2, 3) and parse_shard("1/1") == (1, 1)


def test_a_resume_without_the_shard_runs_what_the_other_shards_left(tmp_path):
    pytest.importorskip("cosmic_ray", reason="the mutation extra is not installed ('.[mutation]')")
    from run import run_again, skip_other_shards
    from test_ledger import MODULE, init
    from cosmic_ray.work_db import WorkDB, use_db

    db = init(tmp_path, MODULE)

    def pending() -> int:
        with use_db(str(db), WorkDB.Mode.open) as work_db:
            return sum(1 for _ in work_db.pending_work_items)

    run_again(db, tmp_path, widen=True, sample=None)  # (every runnable mutant to run: the implausible skipped)
    runnable = pending()
    first = skip_other_shards(db, tmp_path, (1, 2))
    assert pending() == first and 0 < first < runnable
    run_again(db, tmp_path, widen=True, sample=None)  # the other shard, in its own run
    assert skip_other_shards(db, tmp_path, (2, 2)) == runnable - first
    run_again(db, tmp_path, widen=True, sample=None)  # a resume without a shard
    assert pending() == runnable
