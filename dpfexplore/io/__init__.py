"""Reading and writing files, below every stage that does: nothing here knows the model.

It imports nothing from dpfexplore but :mod:`dpfexplore.numerics`, so that every stage (jobs,
scenes, legs, the sweep's storage) can use it.
"""
