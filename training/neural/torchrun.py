"""``torchrun --nproc_per_node N -m training.neural.torchrun CONFIG ...``: the arguments of ``panolight train``,
run data-parallel (training/neural/train.py: DDP over gloo on CPU, nccl on GPU)."""
from __future__ import annotations

import argparse
import sys

from training.neural.command import add_train_arguments, run_train


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="torchrun -m training.neural.torchrun", description=__doc__)
    add_train_arguments(parser)
    return run_train(parser.parse_args(sys.argv[1:] if argv is None else argv))


if __name__ == "__main__":
    raise SystemExit(main())
