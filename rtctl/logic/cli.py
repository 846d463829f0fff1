"""``rtctl leg compile|replay``: the event table's circuit, and its replay in every bit order."""
from __future__ import annotations

from pathlib import Path

from rtctl.logic.emulate import CircuitModel
from rtctl.logic.report import format_compile, format_replay
from rtctl.logic.synth import compile_table
from rtctl.logic.table import load_table
from rtctl.logic.verify import agreement, race_proof, replay

SHIPPED_TABLE = Path(__file__).resolve().parents[2] / "configs" / "leg" / "table3.toml"


def add_parser(sub) -> None:
    leg = sub.add_parser("leg", help="the prosthetic-leg automaton: event table → J-K/PLA circuit; replay",
                         description="Synthesise an event table (the leg paper's Table 3) into a race-free "
                                     "asynchronous J-K flip-flop circuit in a PLA, verify it exhaustively, "
                                     "and replay the table in every order of its bit changes.")
    legsub = leg.add_subparsers(dest="leg_command", required=True, metavar="ACTION")
    for name, text in (("compile", "flow table, guards, state assignment, equations, PLA matrix, checks"),
                       ("replay", "replay the table: every one-at-a-time order of the bits changing between rows")):
        p = legsub.add_parser(name, help=text, description=text)
        p.add_argument("table", nargs="?", default=str(SHIPPED_TABLE),
                       help="event table (TOML; default: the shipped configs/leg/table3.toml)")
        if name == "compile":
            p.add_argument("--pla", metavar="PATH", help="also write the PLA in Berkeley (espresso) .pla format")


def leg_command(args) -> int:
    table = load_table(args.table)
    circuit = compile_table(table)
    model = CircuitModel.from_pla(circuit.pla, table.n_gates, circuit.n_bits)
    if args.leg_command == "replay":
        print(format_replay(circuit, replay(circuit, model)))  # a row some order cannot end in is reported, not an error
        return 0
    agree, race = agreement(circuit, model), race_proof(circuit, model)
    print(format_compile(circuit, agree, race))
    if args.pla:
        Path(args.pla).write_text(circuit.pla.to_espresso(
            f"{table.name}\nsynthesised by rtctl leg compile from {Path(args.table).name}: "
            f"J-K flip-flops Q⁺ = J Q̄ + K̄ Q, state assignment "
            + ", ".join(f"{s}={circuit.assignment.code_str(c)}" for s, c in circuit.assignment.codes.items())))
        print(f"wrote {args.pla}")
    return 0 if not agree["mismatches"] and race.ok else 1  # the synthesis contradicts its own proof: a bug
