"""Stable states of the lattice: Newton minimisation, state search, outputs, batches (Numba).

Modules
-------
newton
    Globalised Newton minimisation of the lattice energy with a caller-set tolerance and cap.
states
    Geometric guess, stable-state search and per-state outputs (MODEL.md §6-§7).
batch
    ``prange`` entry points evaluating many design-states, and their serial twins.
"""
