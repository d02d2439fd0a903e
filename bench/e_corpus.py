"""The scenario corpus with build e's figures changed as ``bench/e_fidelity.py`` changes
them: the landing rule's corpus check for a variant (docs/timing-model.md,
"thirty-second pass").

    python3 bench/e_corpus.py --variant TH --variant U --variant R28 [--set ...] \\
        sequences/conformance sequences/upstream sequences/gcode sequences/examples

The named variants (``--variant``) and the figures (``--set [CHIP:]FIELD=VALUE``)
reach build e's tables of this process; the scenario files then run as
``python3 -m stepperdemo run FILES...`` runs them (its exit status).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import e_fidelity  # noqa: E402

from stepperdemo.front.cli import main as stepperdemo_main  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variant", action="append", default=[],
                    choices=sorted(e_fidelity.VARIANTS),
                    help="a named set of --set (as e_fidelity.py); repeatable")
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE",
                    help="a figure of build e (as e_fidelity.py --set); repeatable")
    ap.add_argument("paths", nargs="+", help="scenario files or folders")
    args = ap.parse_args(argv)
    try:
        e_fidelity.set_timing(e_fidelity.variant_settings(args.variant) + args.set)
    except ValueError as exc:
        print(f"e_corpus: {exc}", file=sys.stderr)
        return 2
    return stepperdemo_main(["run", *args.paths])


if __name__ == "__main__":
    sys.exit(main())
