"""Design sensitivities of stable states by the implicit function theorem (Numba).

Modules
-------
states
    Exact derivatives of a stable state's outputs in the design parameters (forward-mode
    tangent assembly, third-derivative contraction).
batch
    Batch entry points of states with their sensitivities.
"""
