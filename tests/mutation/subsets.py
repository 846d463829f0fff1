"""Which mutants a run takes: a fixed sample (``--sample N``) and disjoint shards
(``--shard K/N``), both chosen from a hash of each mutant's (file, operator, occurrence), so
two commits are compared on the same mutants and N shards cover each mutant exactly once."""
from __future__ import annotations

import argparse
import hashlib
from pathlib import Path


def _hash(key: str) -> int:
    return int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "big")


def sample_key(item, tree: Path) -> str:
    """What ``in_sample`` hashes: the mutant's file (relative to the copy), operator and occurrence."""
    return "|".join(f"{Path(m.module_path).relative_to(tree)}:{m.operator_name}:{m.occurrence}" for m in item.mutations)


def in_sample(key: str, sample: int | None, total: int) -> bool:
    if sample is None or sample >= total:
        return True
    return _hash(key) < sample / total * 2**64


def in_shard(key: str, shard: tuple[int, int] | None) -> bool:
    """Whether the mutant of ``key`` is in part K of N (``shard`` = (K, N), K from 1)."""
    if shard is None:
        return True
    k, n = shard
    return _hash(key) % n == k - 1


def parse_shard(text: str) -> tuple[int, int]:
    """``"K/N"`` → (K, N) with 1 ≤ K ≤ N."""
    k, _, n = text.partition("/")
    if not (k.isdigit() and n.isdigit() and 1 <= int(k) <= int(n)):
        raise argparse.ArgumentTypeError(f"a shard is K/N with 1 ≤ K ≤ N, got {text!r}")
    return int(k), int(n)
