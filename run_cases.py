#!/usr/bin/env python3
"""Run built-in cases or problem files: ``mpirun -n 2 python3 run_cases.py block --refine adaptive``.

See ``python3 run_cases.py --help``; the same as ``python3 -m nc_dolfinx``.
"""
import sys

from nc_dolfinx.cli.command_line import main

if __name__ == "__main__":
    sys.exit(main())
