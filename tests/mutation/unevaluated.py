"""Mutation sites that Python never evaluates (tests/mutation/run.py leaves them out).

In a module with ``from __future__ import annotations`` (PEP 563) every annotation — of an
argument, a return or an annotated assignment (``self.frames: list[Frame | None] = …``, a
dataclass field) — is kept as a string and never evaluated unless someone asks for it
(``typing.get_type_hints``; rtctl does not; ``dataclasses`` only looks for ``ClassVar`` and
``InitVar`` in the string, which no mutation operator writes). A mutant there, such as
``float | None`` → ``float & None``, cannot change behaviour: it is equivalent by construction,
and running the tests for it only costs time and inflates the survival rate. The assigned
value is code, and stays in.
"""
from __future__ import annotations

import ast
from pathlib import Path

Span = tuple[tuple[int, int], tuple[int, int]]  # ((row, column), (row, column)); rows from 1, columns in characters


def _postponed(module: ast.Module) -> bool:
    return any(isinstance(node, ast.ImportFrom) and node.module == "__future__"
               and any(alias.name == "annotations" for alias in node.names) for node in module.body)


def _annotations(module: ast.Module):
    for node in ast.walk(module):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = node.args
            for a in [*args.posonlyargs, *args.args, *args.kwonlyargs, args.vararg, args.kwarg]:
                if a is not None and a.annotation is not None:
                    yield a.annotation
            if node.returns is not None:
                yield node.returns
        elif isinstance(node, ast.AnnAssign):
            yield node.annotation


def _column(lines: list[str], row: int, byte_offset: int) -> int:
    """ast counts columns in UTF-8 bytes; cosmic-ray (parso) in characters."""
    return len(lines[row - 1].encode()[:byte_offset].decode(errors="ignore"))


def annotation_spans(source: str) -> list[Span]:
    """The spans of every annotation Python leaves unevaluated in ``source``: none unless the
    module postpones its annotations."""
    module = ast.parse(source)
    if not _postponed(module):
        return []
    lines = source.splitlines()
    return [((a.lineno, _column(lines, a.lineno, a.col_offset)),
             (a.end_lineno, _column(lines, a.end_lineno, a.end_col_offset))) for a in _annotations(module)]


def unevaluated_jobs(items) -> set[str]:
    """The job ids of cosmic-ray work items whose mutation lies inside an annotation Python
    never evaluates (each module parsed once, as it is on disk now)."""
    spans: dict[Path, list[Span]] = {}
    jobs = set()
    for item in items:
        m = item.mutations[0]
        if m.module_path not in spans:
            spans[m.module_path] = annotation_spans(Path(m.module_path).read_text())
        if any(lo <= tuple(m.start_pos) and tuple(m.end_pos) <= hi for lo, hi in spans[m.module_path]):
            jobs.add(item.job_id)
    return jobs
