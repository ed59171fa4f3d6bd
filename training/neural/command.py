"""``panolight train``'s command line and handler (also ``torchrun -m training.neural.torchrun``)."""
from __future__ import annotations

import sys

from panolight_core.apps.options import stderr_log


def run_train(args) -> int:
    from panolight_core.errors import PanoLightError

    try:
        from training.neural.train import train
    except ImportError as exc:
        raise PanoLightError(f"train needs torch (pip install -e '.[train]'): {exc}") from None
    res = train(args.config, args.data, args.out, epochs=args.epochs, ae_epochs=args.ae_epochs,
                batch_size=args.batch_size, lr=args.lr, seed=args.seed, procedural=args.procedural,
                val_procedural=args.val_procedural, cache=args.cache, max_minutes=args.max_minutes,
                ae_from=args.ae_from, hdr=args.hdr, hdr_copies=args.hdr_copies, hold_out=args.hold_out,
                relight_pool=args.relight_pool, log=stderr_log(args.quiet))
    print(f"train: weights in {res['weights']}", file=sys.stderr)
    return 0


def _fold(text: str) -> tuple[int, int]:
    from training.common.folds import parse_fold

    return parse_fold(text)


def add_train_arguments(tr) -> None:
    """The options of ``panolight train`` (also ``torchrun -m training.neural.torchrun``)."""
    tr.add_argument("config", help="small | paper | ablation/VARIANT (e.g. ablation/full-prior) | a JSON config path")
    tr.add_argument("--data", default=None, help="dataset folder written by 'panolight synth' (optional)")
    tr.add_argument("--hdr", default=None, metavar="DIR",
                    help="a folder of real HDR panoramas (.exr/.hdr, e.g. Laval) added as training examples; "
                         "Blender's studio HDRIs are refused (they are the evaluation set)")
    tr.add_argument("--hdr-copies", type=int, default=0, metavar="N",
                    help="augmented views of each --hdr panorama (yaw, mirror, white balance, resolution, "
                         "ev -3..3, tone curves, JPEG; the per-source model's camera); default 0: one plain view")
    tr.add_argument("--hold-out", type=_fold, default=None, metavar="K/N",
                    help="leave fold K of N of the --hdr scenes out of training and validation (the folds of "
                         "'python -m training.source_energy.fit cv'); score it with 'python -m training.neural.cv'")
    tr.add_argument("--relight-pool", choices=("procedural", "hdr"), default="procedural",
                    help="lightings that relight the --data samples (paper Eq. 5): 256 procedural environments "
                         "(default), or the --hdr panoramas of the same split, 8 yaws each and mirrored, as the "
                         "paper relights with Laval (a held-out fold lights nothing)")
    tr.add_argument("--procedural", type=int, default=4000,
                    help="procedural environments in the training set (default 4000)")
    tr.add_argument("--val-procedural", type=int, default=400, help="procedural validation environments (default 400)")
    tr.add_argument("--cache", default=None, help="folder for the prepared arrays (default: --data, else --out)")
    tr.add_argument("--max-minutes", type=float, default=None,
                    help="stop after the epoch that crosses this training time budget")
    tr.add_argument("--ae-from", default=None, metavar="WEIGHTS",
                    help="start from the autoencoder of this model.safetensors (with --ae-epochs 0: train "
                         "only the lighting encoder, as the ablation variants do)")
    tr.add_argument("--out", required=True, help="run folder")
    tr.add_argument("--epochs", type=int, default=10)
    tr.add_argument("--ae-epochs", type=int, default=2, help="autoencoder-only epochs first (default 2)")
    tr.add_argument("--batch-size", type=int, default=16)
    tr.add_argument("--lr", type=float, default=None,
                    help="Adam learning rate (default: the config's; paper 1e-4, small 1e-3)")
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("-q", "--quiet", action="store_true")
