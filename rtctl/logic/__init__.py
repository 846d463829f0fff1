"""Event table → synthesised asynchronous sequential circuit → emulation (docs/leg_automaton.md).

The prosthetic-leg controller of the leg paper, derived by program: :mod:`table` (the event
table as data), :mod:`flow` (flow table and guards), :mod:`assign` (race-free state
assignment), :mod:`qm` (Quine–McCluskey), :mod:`synth` (J-K excitation and the PLA),
:mod:`pla` (personality, equations, Berkeley ``.pla``), :mod:`emulate` (the compiled
circuit), :mod:`verify` (exhaustive checks and the replay).
"""
from rtctl.logic.emulate import CircuitModel, Emulator
from rtctl.logic.pla import Pla
from rtctl.logic.synth import Circuit, compile_table
from rtctl.logic.table import EventTable, load_table

__all__ = ["EventTable", "load_table", "Circuit", "compile_table", "Pla", "CircuitModel", "Emulator"]
