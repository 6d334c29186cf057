"""Signals: labels of a run (impacts per cycle, regimes, J*, peaks, periodicity), features of
an acceleration record with their spreads, and the sensor chain a recording went through."""
