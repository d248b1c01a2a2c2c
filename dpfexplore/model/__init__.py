"""The model: what a finger is, before anything is solved (MODEL.md §2-§4, §7-§8 inputs).

Modules
-------
design
    :class:`~.design.Design`, :class:`~.design.DesignBatch`, materials, TOML; all input
    validation.
domain
    Limits of the design domain shared with the kernels (``MAX_UNITS``).
constants
    The paper's closed-form spring constants and isolated-dome analysis (MODEL.md §3-§4).
closed_form, constants_set
    Closed forms in ``π1 = t/H``, ``π3 = H/R`` as data, and the constants sets every
    computation runs on (the paper's by default; their domain, fingerprint, files).
set_checks
    A constants set's file read within bounds and its fields checked; its claims proven over
    its whole domain (Bernstein bounds of its closed forms).
quantities
    The tables that declare the model's quantities, one row each: a stable state's output
    columns and a constants set's closed forms (the kernels, results, datasets, set files and
    identification read them), with the recipes for a new one.
materials, limits, formatting
    Material presets; front-end limits; number formatting for output.
pressure
    Piecewise-linear pressure profiles (MODEL.md §8).
gripper
    The gripper transform and aperture of a finger shape (MODEL.md §7).
variables
    :class:`~.variables.DesignVariables`: bounds and constraints as an exact map of the unit
    box (lookup's polish and inverse design), and the parameter order of the sensitivities.
status
    Status codes shared by kernels, API and stored datasets.
version
    Model version and library versions recorded with every stored result.
"""
