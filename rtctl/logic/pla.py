"""A PLA personality: the AND plane (product terms over the inputs) and the OR plane (which
outputs each term drives); its equations, its matrix, and Berkeley's ``.pla`` format.

The ``.pla`` file is espresso's (``.i .o .ilb .ob .p``, type ``f``: an output column is 1 where
the term is in that output's ON-set), so the circuit can be read by espresso and other tools.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from rtctl.errors import RtctlError
from rtctl.logic.qm import Cube


@dataclass(frozen=True)
class Pla:
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    terms: tuple[Cube, ...]  # AND plane: (care, value) over the inputs, bit i = inputs[i]
    plane: np.ndarray  # OR plane: [term, output] bool

    @classmethod
    def from_functions(cls, inputs, functions: dict) -> "Pla":
        """One term per distinct product term of the functions (sums of cubes), in order of use."""
        terms: list[Cube] = []
        for cubes in functions.values():
            for c in cubes:
                if c not in terms:
                    terms.append(c)
        plane = np.zeros((len(terms), len(functions)), dtype=bool)
        for o, cubes in enumerate(functions.values()):
            for c in cubes:
                plane[terms.index(c), o] = True
        return cls(tuple(inputs), tuple(functions), tuple(terms), plane)

    @property
    def n_terms(self) -> int:
        return len(self.terms)

    @property
    def n_literals(self) -> int:
        return sum(care.bit_count() for care, _ in self.terms)

    def function(self, name: str) -> list[Cube]:
        o = self.outputs.index(name)
        return [t for t, used in zip(self.terms, self.plane[:, o]) if used]

    def and_row(self, term: Cube) -> str:
        care, value = term
        return "".join("-" if not care >> i & 1 else str(value >> i & 1) for i in range(len(self.inputs)))

    # -- text ------------------------------------------------------------------------------
    def matrix(self) -> str:
        """The personality as a table: one row per product term, AND plane | OR plane."""
        width = max(len(n) for n in self.inputs + self.outputs)
        lines = []
        for r in range(width):  # column headers written vertically, bottom-aligned
            def cell(name):
                return name[r - width + len(name)] if r >= width - len(name) else " "
            lines.append("     " + "".join(cell(n) for n in self.inputs) + " | " + "".join(cell(n) for n in self.outputs))
        lines.append("     " + "-" * len(self.inputs) + "-+-" + "-" * len(self.outputs))
        for k, term in enumerate(self.terms):
            ors = "".join("1" if u else "." for u in self.plane[k])
            lines.append(f"P{k + 1:<3} {self.and_row(term)} | {ors}")
        return "\n".join(lines)

    def equations(self, style: str = "text") -> list[str]:
        """``name = term + term …`` per output; ``style`` "text" (¬x) or "latex" (\\bar{x})."""
        if style not in ("text", "latex"):
            raise ValueError(f"style must be 'text' or 'latex', not {style!r}")
        out = []
        for name in self.outputs:
            terms = [self._term_str(t, style) for t in self.function(name)]
            lhs = _latex_name(name) if style == "latex" else name
            out.append(f"{lhs} = {' + '.join(terms) if terms else '0'}")
        return out

    def _term_str(self, term: Cube, style: str) -> str:
        care, value = term
        lits = []
        for i, name in enumerate(self.inputs):
            if care >> i & 1:
                positive = bool(value >> i & 1)
                if style == "latex":
                    lits.append(_latex_name(name, bar=not positive))
                else:
                    lits.append(name if positive else f"¬{name}")
        if not lits:
            return "1"
        return (r"\," if style == "latex" else " ").join(lits)

    # -- Berkeley .pla -----------------------------------------------------------------------
    def to_espresso(self, comment: str = "") -> str:
        lines = [f"# {line}" for line in comment.splitlines()]
        lines += [f".i {len(self.inputs)}", f".o {len(self.outputs)}", ".ilb " + " ".join(self.inputs),
                  ".ob " + " ".join(self.outputs), ".type f", f".p {self.n_terms}"]
        for k, term in enumerate(self.terms):
            lines.append(f"{self.and_row(term)} {''.join('1' if u else '0' for u in self.plane[k])}")
        lines.append(".e")
        return "\n".join(lines) + "\n"

    @classmethod
    def from_espresso(cls, text: str) -> "Pla":
        """Parse a ``.pla`` of type f (or fd, whose ``-`` outputs are read as 0)."""
        ni = no = None
        ilb = ob = None
        rows = []
        for number, raw in enumerate(text.splitlines(), 1):
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            if line.startswith("."):
                key, _, rest = line.partition(" ")
                if key == ".i":
                    ni = int(rest)
                elif key == ".o":
                    no = int(rest)
                elif key == ".ilb":
                    ilb = tuple(rest.split())
                elif key == ".ob":
                    ob = tuple(rest.split())
                elif key == ".type" and rest.strip() not in ("f", "fd"):
                    raise RtctlError(f"line {number}: only .type f or fd is supported, not {rest.strip()!r}")
                elif key == ".e":
                    break
                continue
            if ni is None or no is None:
                raise RtctlError(f"line {number}: a product term before .i and .o")
            bits = re.sub(r"\s+", "", line)
            if len(bits) != ni + no or set(bits[:ni]) - set("01-") or set(bits[ni:]) - set("01-~"):
                raise RtctlError(f"line {number}: expected {ni} input and {no} output characters, got {line!r}")
            care = sum(1 << i for i, ch in enumerate(bits[:ni]) if ch != "-")
            value = sum(1 << i for i, ch in enumerate(bits[:ni]) if ch == "1")
            rows.append(((care, value), [ch == "1" for ch in bits[ni:]]))
        if ni is None or no is None:
            raise RtctlError("not a .pla: .i and .o are missing")
        inputs = ilb or tuple(f"x{i}" for i in range(ni))
        outputs = ob or tuple(f"y{o}" for o in range(no))
        if len(inputs) != ni or len(outputs) != no:
            raise RtctlError(".ilb/.ob do not match .i/.o")
        plane = np.array([r[1] for r in rows], dtype=bool).reshape(len(rows), no)
        return cls(inputs, outputs, tuple(r[0] for r in rows), plane)

    def truth_tables(self) -> np.ndarray:
        """[minterm, output] bool over all 2^inputs minterms (for checks; small PLAs only)."""
        m = np.arange(1 << len(self.inputs), dtype=np.int64)
        active = np.stack([(m & care) == value for care, value in self.terms], axis=1) if self.terms else \
            np.zeros((m.size, 0), dtype=bool)
        return (active.astype(np.int64) @ self.plane.astype(np.int64)) > 0


def _latex_name(name: str, bar: bool = False) -> str:
    """t_d → t_d, K_d1 → K_{d1}, Q1 → Q_1, K1' → K_1' (with \\bar over the letter if asked)."""
    prime = "'" if name.endswith("'") else ""
    core = name.rstrip("'")
    m = re.fullmatch(r"([A-Za-z]+)_?([A-Za-z0-9]*)", core)
    base, sub = (m.group(1), m.group(2)) if m else (core, "")
    head = rf"\bar{{{base}}}" if bar else base
    return head + (f"_{{{sub}}}" if sub else "") + prime
