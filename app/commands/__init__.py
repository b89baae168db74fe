"""Sub-commands of the ``hyst`` command line, one module each.

Each module defines ``register(subparsers)`` that adds its sub-parser and sets
``func=<callable(args) -> int>`` as the parser default. :mod:`app.cli` discovers them.
"""
