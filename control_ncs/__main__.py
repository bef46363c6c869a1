"""Command line: ``python -m control_ncs demo [--out DIR]``."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``python -m control_ncs`` and the ``control-ncs`` script."""
    parser = argparse.ArgumentParser(
        prog="python -m control_ncs",
        description="control_ncs: networked control systems for python-control")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="design and verify a passive networked "
                          "controller for a levitation stage; write PNG plots")
    demo.add_argument("--out", default="demo-output",
                      help="folder for the plots (default: demo-output)")
    demo.add_argument("--trials", type=int, default=200,
                      help="Monte Carlo sample paths (default: 200)")
    demo.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    from .demo import run_demo_command
    run_demo_command(args.out, trials=args.trials, seed=args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
