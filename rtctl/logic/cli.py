"""``rtctl leg compile|replay``: the event table's circuit, and its replay in every bit order."""
from __future__ import annotations

from pathlib import Path

from rtctl.logic.emulate import CircuitModel
from rtctl.logic.report import format_compile, format_replay
from rtctl.logic.synth import compile_table
from rtctl.logic.table import load_table
from rtctl.logic.verify import agreement, race_proof, replay

def leg_command(args) -> int:
    if args.leg_command == "compile" and args.pla:
        from rtctl.outputs import output_path

        args.pla = output_path(args.pla, "--pla")
    table = load_table(args.table)
    circuit = compile_table(table, args.semantics)
    # the proofs hold the circuit to what its routes need: one pass per flip-flop change + one that confirms
    model = CircuitModel.from_pla(circuit.pla, table.n_gates, circuit.n_bits, circuit.settle_passes)
    if args.leg_command == "replay":
        print(format_replay(circuit, replay(circuit, model)))  # a row some order cannot end in is reported, not an error
        return 0
    agree, race = agreement(circuit, model), race_proof(circuit, model)
    print(format_compile(circuit, agree, race))
    print(f"Settles within {model.max_passes} passes (leg_automaton.max_passes must be at least that)")
    if args.pla:
        Path(args.pla).write_text(circuit.pla.to_espresso(
            f"{table.name}\nsynthesised by rtctl leg compile from {Path(args.table).name}: "
            f"J-K flip-flops Q⁺ = J Q̄ + K̄ Q, state assignment "
            + ", ".join(f"{s}={circuit.assignment.code_str(c)}" for s, c in circuit.assignment.codes.items())))
        print(f"wrote {args.pla}")
    return 0 if not agree["mismatches"] and race.ok else 1  # the synthesis contradicts its own proof: a bug
