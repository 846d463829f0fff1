"""Text reports for ``rtctl leg compile`` and ``rtctl leg replay``."""
from __future__ import annotations

from rtctl.logic.flow import guards
from rtctl.logic.synth import Circuit


def _literal_term(table, term) -> str:
    care, value = term
    lits = [g if value >> i & 1 else f"¬{g}" for i, g in enumerate(table.gates) if care >> i & 1]
    return " ".join(lits) or "1"


def format_compile(circuit: Circuit, agreement: dict, race) -> str:
    table, flow, a, pla = circuit.table, circuit.flow, circuit.assignment, circuit.pla
    out = [f"{table.file}: {table.name} ({circuit.semantics} semantics)",
           f"{len(table.states)} rows, {len(flow.states)} states, {table.n_gates} gates "
           f"({' '.join(table.gates)}), {table.n_actuators} actuator bits ({' '.join(table.actuators)})", "",
           "Flow table (gate bits in the order above; every other vector holds the state):"]
    for s in flow.states:
        stays = ", ".join(table.gate_bits(x) for x in sorted(flow.stay[s]))
        exits = ", ".join(f"{table.gate_bits(x)} → {t}" for x, t in sorted(flow.exits[s].items()))
        out.append(f"  state {s} [{table.actuator_bits(table.outputs[s])}]  stays on {stays};  exits {exits}")
    out += ["", "Transition guards (fewest literals separating each exit from the vectors seen in its state):"]
    for g in guards(flow):
        tr = g.transition
        alts = " | ".join(_literal_term(table, term) for term in g.terms)
        out.append(f"  {tr.state} → {tr.next} (step {table.steps[tr.row]}):  {alts}")
    if circuit.guard is not None:
        out += ["", "Guard semantics (each exit fires on its guard; two guards at once, or a cycle of them, hold):"]
        for (s, t), terms in circuit.guard.exit_terms.items():
            out.append(f"  {s} → {t}:  " + " + ".join(_literal_term(table, term) for term in terms))
        unused = [g for i, g in enumerate(table.gates) if not any(c >> i & 1 for c, _ in pla.terms)]
        out.append("  gates the circuit does not read: " + (", ".join(unused) or "none"))
    else:
        out += ["", "Exact semantics: each exit fires on its table vector only; every other vector holds."]
    q = " ".join(f"Q{k + 1}" for k in range(a.n_bits))
    out += ["", f"State assignment ({a.n_bits} J-K flip-flops, {q}; code 0 at power-on):"]
    for s in flow.states:
        out.append(f"  state {s} = {a.code_str(a.codes[s])}")
    for c in a.spare:
        used = any(c in path[1:-1] for path in a.routes.values())
        out.append(f"  {a.code_str(c)} spare" + (", unstable intermediate state" if used else ", unused (don't care)"))
    for (s, x), path in a.routes.items():
        if len(path) > 2:
            t = a.state_of(path[-1])
            out.append(f"  {s} → {t} routed " + " → ".join(a.code_str(c) for c in path) + " (no adjacent code is free)")
    proved = "minimised exactly" if not circuit.unproved else (
        "minimised exactly except " + ", ".join(circuit.unproved) + ": the best cover found within the search budget")
    out += ["", f"Equations (J-K excitation Q⁺ = J Q̄ + K̄ Q, outputs; {proved}):"]
    out += [f"  {e}" for e in pla.equations()]
    out += ["", f"PLA personality: {pla.n_terms} product terms, {pla.n_literals} literals, "
                f"{len(pla.inputs)} inputs, {len(pla.outputs)} outputs", pla.matrix(), "",
            "Verification (exhaustive):",
            f"  circuit = automaton on all {agreement['pairs']} (state, gates) pairs: "
            f"{agreement['exit']} exits, {agreement['stay']} stays, "
            + (f"{agreement['guard']} guard exits on vectors the table does not show, " if circuit.guard else "")
            + f"{agreement['hold']} holds — "
            + ("OK" if not agreement["mismatches"] else f"{len(agreement['mismatches'])} MISMATCHES"),
            f"  no critical race: every flip-flop order from every state under every gate vector "
            f"({race.checked} cases; {race.races} with a choice of order) ends in the one stable state, "
            f"at most {race.longest} changes — " + ("OK" if race.ok else f"{len(race.failures)} FAILURES")]
    for m in agreement["mismatches"][:5]:
        out.append(f"    mismatch: {m}")
    for f in race.failures[:5]:
        out.append(f"    race: {f}")
    return "\n".join(out)


def format_replay(circuit: Circuit, rows) -> str:
    table = circuit.table
    total = sum(r.orders for r in rows)
    good = sum(r.ok for r in rows)
    out = [f"{table.file}: Table replay, every one-at-a-time order of the gate bits that change between rows",
           f"{'row':>4} {'step':>5}  {'changed gates':<32} {'orders':>7} {'ok':>5}  state"]
    for r in rows:
        changed = " ".join(r.changed) or "(none)"
        out.append(f"{r.row:>4} {r.step:>5}  {changed:<32} {r.orders:>7} {r.ok:>5}  {table.states[r.row]}")
        for f in r.failures:
            out.append(f"             order {' '.join(f['order'])}: {f['why']}")
    bad = [r for r in rows if r.ok != r.orders]
    out.append(f"{good} of {total} orders end in the table's state"
               + ("" if not bad else f"; rows where some order cannot: {', '.join(str(r.step) for r in bad)}"))
    return "\n".join(out)
