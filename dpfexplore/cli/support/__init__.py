"""What the commands share: one place for argument parsing, inputs and output.

Modules
-------
help
    The plain-text help formatter and one-line argparse errors.
inputs
    Reading the inputs commands share: a ``DESIGN`` argument, saved results, ``--constants``.
output
    Streams that survive closed pipes, JSON on stdout, output paths checked before the work,
    compile notices, the fitted-range line.
"""
