import pytest

from leg_helpers import TABLE3
from rtctl.logic import CircuitModel, compile_table, load_table


@pytest.fixture(scope="session")
def table3():
    return load_table(TABLE3)


@pytest.fixture(scope="session")
def circuit(table3):
    return compile_table(table3)


@pytest.fixture(scope="session")
def model(circuit, table3):
    return CircuitModel.from_pla(circuit.pla, table3.n_gates, circuit.n_bits)
