"""On-line identification (docs/arma_kalman.md): the per-joint ARX model and the Sage–Husa
adaptive Kalman filter of Qu & Jiang's adaptive controller — used by the ``arma_gmv``
controller every sample, and offline on recorded runs (:func:`identify`, ``rtctl identify``)."""
from rtctl.estimation.arx import ArxOrder, push_history, regressor_into, simulate
from rtctl.estimation.identify import identify
from rtctl.estimation.sage_husa import QUANTITIES, SWITCH_NAMES, SageHusa, sage_husa_step

__all__ = ["ArxOrder", "SageHusa", "sage_husa_step", "regressor_into", "push_history", "simulate", "identify",
           "QUANTITIES", "SWITCH_NAMES"]
