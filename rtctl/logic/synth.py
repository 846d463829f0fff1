"""Event table → J-K flip-flop circuit in a PLA (synthesis steps 4 and 5).

Variables of the excitation functions: the n gate bits, then the state bits Q1…Qb (minterm
bit i = gate i, bit n + k = Q(k+1)). For each flip-flop the next-state specification of the
flow table and the assignment (hold, exit, route step; don't-care on spare codes no route
uses) gives J and K through the J-K excitation table of Q⁺ = J Q̄ + K̄ Q:

    Q → Q⁺:  0 → 0: J = 0, K = –    0 → 1: J = 1, K = –    1 → 0: J = –, K = 1    1 → 1: J = –, K = 0

The Moore outputs are functions of the state bits alone (spare codes don't-care). Each
function is minimised exactly (:mod:`rtctl.logic.qm`); the PLA's AND plane is the set of
distinct product terms, its OR plane which functions use each. Among the candidate
assignments the smallest PLA wins (fewest product terms, then literals).

Two semantics (docs/leg_automaton.md): ``"exact"`` moves only on the gate vectors the table
shows and holds on every other; ``"guard"`` fires each exit on its guard, the single gate
events of the paper's Fig. 8 (:mod:`rtctl.logic.guard`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rtctl.errors import ConfigError
from rtctl.logic.assign import Assignment, AssignmentError, SearchResult, candidate_assignments
from rtctl.logic.flow import FlowTable, flow_table
from rtctl.logic.guard import GuardAutomaton, firing_masks, guard_automaton, guard_spec
from rtctl.logic.pla import Pla
from rtctl.logic.qm import MAX_VARIABLES, minimise_proved
from rtctl.logic.table import EventTable

DONT_CARE = -1
SEMANTICS = ("guard", "exact")


@dataclass(frozen=True)
class Circuit:
    flow: FlowTable
    assignment: Assignment
    functions: dict  # name → list of cubes over gates + state bits, in PLA output order
    spec: np.ndarray  # [code, gates] → specified next code, or DONT_CARE
    pla: Pla
    unproved: tuple[str, ...] = ()  # functions whose cover was not proved minimum within its budget
    search: SearchResult | None = None  # how the assignment was found (None: given)
    guard: GuardAutomaton | None = None  # the guard semantics' automaton; None: exact semantics

    @property
    def semantics(self) -> str:
        return "exact" if self.guard is None else "guard"

    @property
    def settle_passes(self) -> int:
        """Passes a settle needs: one per flip-flop change on the longest path the spec takes
        from a state's code (a route; under the guard semantics a chain of exits), and one that
        finds nothing more to change."""
        longest = 0
        for c in self.assignment.codes.values():
            for x in range(self.spec.shape[1]):
                q, n = c, 0
                while self.spec[q, x] != q:
                    q, n = int(self.spec[q, x]), n + 1
                longest = max(longest, n)
        return longest + 1

    def next_state(self, state: int, gates: int) -> int:
        """δ of the semantics the circuit was synthesised for."""
        return self.flow.next_state(state, gates) if self.guard is None else self.guard.next_state(state, gates)

    @property
    def table(self) -> EventTable:
        return self.flow.table

    @property
    def n_bits(self) -> int:
        return self.assignment.n_bits


def next_code_spec(flow: FlowTable, a: Assignment) -> np.ndarray:
    """[code, gates] → the next code the circuit must take one step towards (one bit away),
    or DONT_CARE on spare codes where no route passes under that gate vector."""
    spec = np.full((1 << a.n_bits, 1 << flow.n_gates), DONT_CARE, dtype=np.int64)
    for s, c in a.codes.items():
        spec[c, :] = c  # stay, and hold on every vector never seen in s
    for (s, x), path in a.routes.items():
        spec[path[0], x] = path[1]
    for (c, x), nxt in a.intermediates.items():
        spec[c, x] = nxt
    return spec


def excitation(spec: np.ndarray, n_gates: int, k: int):
    """ON-sets and don't-care sets of J and K for flip-flop k: ((J_on, J_dc), (K_on, K_dc))."""
    codes, gates = (a.ravel() for a in np.indices(spec.shape))
    nxt = spec.ravel()
    minterm = gates | (codes << n_gates)
    q = codes >> k & 1
    q_next = nxt >> k & 1
    free = nxt == DONT_CARE
    j_on = minterm[~free & (q == 0) & (q_next == 1)]
    j_dc = minterm[free | (q == 1)]
    k_on = minterm[~free & (q == 1) & (q_next == 0)]
    k_dc = minterm[free | (q == 0)]
    return (j_on, j_dc), (k_on, k_dc)


def synthesise(flow: FlowTable, a: Assignment, guard: GuardAutomaton | None = None) -> Circuit:
    ng, nb = flow.n_gates, a.n_bits
    spec = next_code_spec(flow, a) if guard is None else guard_spec(guard, a)
    functions, unproved = {}, []

    def put(name, cubes_proved, shift=0):
        cubes, proved = cubes_proved
        functions[name] = [(care << shift, value << shift) for care, value in cubes]
        if not proved:
            unproved.append(name)

    for k in range(nb):  # J1 K1 J2 K2 …: the flip-flops' inputs, then the actuator bits
        (j_on, j_dc), (k_on, k_dc) = excitation(spec, ng, k)
        put(f"J{k + 1}", minimise_proved(ng + nb, j_on, j_dc))
        put(f"K{k + 1}", minimise_proved(ng + nb, k_on, k_dc))
    spare = list(a.spare)
    for i, name in enumerate(_output_names(flow.table, nb)):
        on = [c for s, c in a.codes.items() if flow.table.outputs[s] >> i & 1]
        put(name, minimise_proved(nb, on, spare), shift=ng)  # over the state bits: the gates don't care
    inputs = flow.table.gates + tuple(f"Q{k + 1}" for k in range(nb))
    return Circuit(flow, a, functions, spec, Pla.from_functions(inputs, functions), tuple(unproved), guard=guard)


def _output_names(table: EventTable, nb: int) -> tuple[str, ...]:
    """The actuator bits' names in the PLA; one that clashes with a flip-flop input (the
    table's K1, K2 against K1…Kb) is primed, as the paper renames K1 K2 to K1' K2'."""
    jk = {f"{p}{k + 1}" for p in "JK" for k in range(nb)}
    return tuple(f"{n}'" if n in jk else n for n in table.actuators)


def compile_table(table: EventTable, semantics: str = "exact") -> Circuit:
    """The whole synthesis: flow table, assignment search, excitation, minimisation, PLA;
    the candidate with the smallest PLA (fewest product terms, then literals; a tie goes to the
    first in code order). A table without a race-free assignment is a :class:`ConfigError`
    naming its ``rows``."""
    if semantics not in SEMANTICS:
        raise ValueError(f"semantics must be one of {SEMANTICS}, got {semantics!r}")
    flow = flow_table(table)
    guard = guard_automaton(flow) if semantics == "guard" else None
    try:
        search = candidate_assignments(flow, firing=None if guard is None else firing_masks(guard))
    except AssignmentError as e:
        raise ConfigError(table.file, "rows", f"transitions that a race-free state assignment can code ({e})") from None
    bits = search.candidates[0].n_bits
    if flow.n_gates + bits > MAX_VARIABLES:
        raise ConfigError(table.file, "gates", f"at most {MAX_VARIABLES - bits} gates for a table that needs {bits} "
                                               f"flip-flops (the PLA's inputs, gates + flip-flops, are at most "
                                               f"{MAX_VARIABLES}); got {flow.n_gates}")
    best = None
    for a in search.candidates:
        circuit = synthesise(flow, a, guard)
        cost = (circuit.pla.n_terms, circuit.pla.n_literals)
        if best is None or cost < best[0]:
            best = (cost, circuit)
    return replace(best[1], search=search)

