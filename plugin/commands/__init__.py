"""One module per ``loadpath`` subcommand.

Each module defines ``HELP`` (one line), ``add_args(parser)`` and ``run(args) -> int``.  Modules import
heavy dependencies (scipy, gmsh, osqp, matplotlib) inside ``run`` so that ``loadpath --help`` and the
interpreter start stay fast.
"""
