"""Hard limits of the model that front ends need without loading Numba."""

#: Largest number of units a design may have (MODEL.md §2: ``N`` from 1 to 12).
MAX_UNITS = 12
