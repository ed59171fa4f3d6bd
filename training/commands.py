"""The checkout's commands for ``panolight``: train, synth, sheet and render-mitsuba with their own options
here, and every other tool of training/ (TOOLS: the model fits, the studies, the benchmarks) under
``panolight dev TOOL`` with its own command line, so that ``panolight --help`` lists what users run.

Registered through the ``panolight.commands`` entry point (pyproject.toml), so the core's CLI never
imports training code; each command imports its module (torch, Mitsuba) only when it runs.
"""
from __future__ import annotations

import sys

from panolight_core.apps.options import HelpFormatter, resolution, stderr_log
from panolight_core.pipeline.settings import number
from training.neural.command import add_train_arguments, run_train


def run_render_mitsuba(args) -> int:
    from training.render.mitsuba import render_figure

    res = render_figure(args.inputs, args.out, meshes=args.meshes, spp=args.spp, resolution=args.resolution_wh,
                        yaw=args.yaw, pitch=args.pitch, fov=args.fov, materials=args.materials,
                        in_panorama=not args.no_panorama_view, compare_hdr=args.compare_hdr,
                        from_ldr=args.from_ldr, log=stderr_log(args.quiet))
    print(f"render-mitsuba: {len(res['renders'])} EXR renders and {res['figure']} in {res['seconds']:.0f} s "
          f"({res['variant']}, {res['spp']} spp)", file=sys.stderr)
    return 0


def run_synth(args) -> int:
    from panolight_core.apps.batch import Progress, parse_shard
    from training.synth.store import synthesize

    w, h = args.resolution
    shard = parse_shard(args.shard)
    count = len(range(shard[0] - 1, args.count, shard[1]))
    prog = Progress(count, args.quiet)
    res = synthesize(args.out, args.count, h, args.spp, args.seed, shard, progress=prog.step)
    per = res["seconds_per_sample"]
    print(f"synth: {res['rendered']} rendered, {res['skipped']} already there, in {res['seconds']:.0f} s"
          + (f" ({per:.2f} s per sample)" if per else "") + f"; {args.out}", file=sys.stderr)
    return 0


def run_sheet(args) -> int:
    from training.neural.contact_sheet import contact_sheet

    path = contact_sheet(args.dataset, args.output, count=args.count, seed=args.seed)
    print(f"sheet: {path}", file=sys.stderr)
    return 0


# name: (module with main(argv), one line of help). ``panolight dev NAME --help`` shows the module's own options;
# ``python -m MODULE`` runs the same main (docs/development.md)
TOOLS = {
    "source-energy": ("training.source_energy.fit", "train (ship) or cross-validate (cv) the per-source energy model"),
    "source-regressors": ("training.experiments.regressors", "experiment, not kept: the per-source trees against "
                          "small networks, region by region, out of fold"),
    "accuracy-report": ("training.source_energy.report", "docs/accuracy.md and .png from eval.json and the "
                        "source-energy cross-validation"),
    "keylight-cv": ("training.keylight.cv", "the key light's direction and energy over the real HDRs, and the "
                    "clear-sky correction cross-validated"),
    "captures": ("training.keylight.captures", "better captures (EVALUATION.md): an HDR clipped at +2/+4/+6 stops, as "
                 "it is and restored, and bracket sets, against one JPEG, scored by the dominant source, its shadow "
                 "and m-RMSE"),
    "bracket-alignment": ("training.experiments.bracket_alignment", "bracket sets aligned over the real HDRs: still "
                          "frames left in place, moved frames put back"),
    "restore-previews": ("training.experiments.restore_previews", "panolight estimate's previews of real scenes "
                         "clipped at +4 stops: as they are, restored, and the truth (docs/studies/restore_previews.jpg)"),
    "bracket-agreement": ("training.experiments.bracket_agreement", "bracket sets' frames against their exposures over "
                          "the real HDRs and four camera curves: right sets passed, reversed or mixed-scene sets refused"),
    "bracket-merge": ("training.experiments.bracket_merge", "the bracket merge's dark-ring rule and camera-curve gain "
                      "against the rules they replaced over the real HDRs (docs/studies/captures.md)"),
    "small-inputs": ("training.experiments.small_inputs", "clipped suns weighed in panoramas 1024 down to 128 wide: "
                     "the JPEG and the HDR clipped at +4 stops, the evidence for the narrow-file warning"),
    "energy-oracle": ("training.experiments.energy_oracle", "experiment: a restored HDR's key light given the "
                      "truth's energy, and other ways of combining the trees' and the sky fit's estimates (issue 45)"),
    "restore-harm": ("training.experiments.restore_harm", "experiment: what restoring does to a clipped HDR file on "
                     "every scene, with a dominant source or none: m-RMSE over the file as it is, energy added over lost"),
    "keylight-rules": ("training.keylight.rules", "the key lights' energy rules and gates compared over the real HDRs"),
    "hidden-sun": ("training.keylight.hidden_sun", "a sun the photo does not show: located from the sky alone over "
                   "the real HDRs, and the suns the estimator invents"),
    "glare-law": ("training.experiments.glare_law", "experiment, not kept: the glare law c E theta^-2 around clipped regions over the real "
                  "HDRs, and the gates that could trust it"),
    "do-no-harm": ("training.experiments.do_no_harm", "the default's decisions priced for harm (issue 58): the fill's "
                   "guard over the 68 % range and the sky-alone sun, against the rules they replaced, harmed scenes "
                   "first"),
    "eevee-units": ("training.experiments.eevee_units", "Blender's physical build rendered by Cycles and EEVEE: a "
                    "white plane's irradiance against lighting.json's, per build (SH + sun lamps, HDRI)"),
    "key-variants": ("training.experiments.key_variants", "experiment: what a key light carries (one account of its "
                     "region, a sure sun at its belief; issue 46), scored by the key-light cross-validation"),
    "digests": ("training.digests", "digests of the shipped estimates over the real HDRs: prove a refactoring "
                "changed nothing (--out, then --compare)"),
    "sky-table": ("training.keylight.sky_table", "tabulate Mitsuba's sunsky into models/sky.safetensors"),
    "artist-check": ("training.render.artist_check", "a white sphere composited into real photos under each "
                     "estimate (Mitsuba), with lit/shadow ratios"),
    "neural-cv": ("training.neural.cv", "leave-scenes-out test of trained networks beside the per-source model"),
    "ablation": ("training.neural.ablation", "the paper's ablation (Table 1): train and evaluate its variants"),
    "ship": ("training.neural.ship", "ship a trained run as the learned estimator's weights, with its model card"),
    "eval-synthetic": ("training.synth.evaluate", "the LDR estimators on procedural skies and rooms"),
    "bench-estimate": ("training.benchmarks.bench_estimate", "benchmark: decode + estimate of a 2048 x 1024 JPEG"),
    "bench-restore": ("training.benchmarks.bench_restore", "benchmark: an 8K clipped HDR restored, and a 3-bracket "
                      "set, against their peers"),
    "bench-captures": ("training.benchmarks.bench_captures", "benchmark: each capture's time to the estimate, beside "
                       "its accuracy (JPEG, brackets, clipped HDRs, RAW)"),
    "bench-merge": ("training.benchmarks.bench_merge", "benchmark: the bracket merge against OpenCV's calibrated Debevec "
                    "merge (time, agreement, fireflies) on noisy camera sets of real HDRs, or a real set's folder"),
    "bench-io": ("training.benchmarks.bench_io", "benchmark: decode time per format, peak memory per size"),
    "bench-neural": ("training.benchmarks.bench_neural", "benchmark: the learned estimator's network latency"),
    "bench-scale": ("training.benchmarks.bench_scale", "benchmark: 16K CLI, 8K/16K Blender and batch throughput"),
    "bench-sh": ("training.benchmarks.bench_sh", "benchmark: the SH engine against its peers"),
    "bench-synth": ("training.benchmarks.bench_synth", "benchmark: training-data rendering and relighting speed"),
    "headroom": ("training.benchmarks.headroom", "oracles: how good any LDR estimator can get on the public set"),
}


def run_tool(args) -> int:
    """Run a TOOLS module's main with the arguments after the tool's name (its usage says panolight dev NAME)."""
    import importlib

    from panolight_core.errors import PanoLightError

    try:
        module = importlib.import_module(TOOLS[args.tool][0])
    except ModuleNotFoundError as exc:  # an extra this machine lacks (torch, mitsuba, sphericart, matplotlib)
        if exc.name and exc.name.split(".")[0] in ("training", "panolight_core"):
            raise
        raise PanoLightError(f"{args.tool} needs the package {exc.name!r}, which is not installed here: run "
                             f"scripts/setup.sh, or pip install -e '.[train,mitsuba,bench,plot]'") from None
    argv0, sys.argv[0] = sys.argv[0], f"panolight dev {args.tool}"
    try:
        return module.main(list(args.forwarded)) or 0
    finally:
        sys.argv[0] = argv0


def register(sub) -> None:
    """Add the training commands to the ``panolight`` sub-command parsers ``sub``."""
    fmt = HelpFormatter
    m = sub.add_parser("render-mitsuba", help="render the paper's bunny/armadillo figure with Mitsuba 3",
                       formatter_class=fmt,
                       description="Render meshes with a mirror, rough plastic (ior 1.9) and gold material under the "
                                   "lighting estimated from each INPUT (a panorama or a lighting.json), composited "
                                   "over the panorama by differential rendering, and assemble figure.png.",
                       epilog="examples:\n"
                              "  panolight render-mitsuba city.jpg --out out/fig --spp 16       # quick look\n"
                              "  panolight render-mitsuba a.exr b.jpg --out out/fig              # 512 spp, the paper's\n"
                              "  panolight render-mitsuba s.exr --out o --compare-hdr            # add the HDR-lit row\n"
                              "Uses llvm_ad_rgb when LLVM 19 is installed (apt-get install libllvm19), else scalar_rgb.")
    m.add_argument("inputs", nargs="+", help="panoramas (estimated here) or lighting.json files")
    m.add_argument("--out", required=True, help="output folder (created)")
    m.add_argument("--meshes", nargs="+", default=None,
                   help=".ply/.obj meshes with +Y up (default: ../shared/data/meshes/bunny.ply and armadillo.obj)")
    m.add_argument("--spp", type=number("--spp", 1, 1 << 20, integer=True), default=512,
                   help="samples per pixel (default 512, the paper's)")
    m.add_argument("--resolution", dest="resolution_wh", type=lambda t: tuple(int(v) for v in t.lower().split("x")),
                   default=(320, 240), help="perspective render size WxH (default 320x240)")
    m.add_argument("--yaw", type=float, default=0.0, help="view azimuth in degrees, 0 = panorama centre, 90 = "
                                                          "a quarter width to the left (default 0)")
    m.add_argument("--pitch", type=float, default=-12.0, help="view elevation in degrees (default -12)")
    m.add_argument("--fov", type=float, default=50.0, help="horizontal field of view in degrees (default 50)")
    m.add_argument("--materials", nargs="+", default=["mirror", "plastic", "gold"], help="columns of the figure")
    m.add_argument("--compare-hdr", action="store_true", help="add a row lit by the input HDR itself")
    m.add_argument("--from-ldr", type=float, default=None, metavar="EV",
                   help="estimate each HDR input from the JPEG an auto-exposing camera takes of it at this ev "
                        "(EVALUATION.md, q90), as the paper's figure estimates from photographs; with "
                        "--compare-hdr the ground-truth row is the HDR in the JPEG's units")
    m.add_argument("--no-panorama-view", action="store_true", help="skip the objects-in-the-panorama renders")
    m.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    m.set_defaults(func=run_render_mitsuba)

    sy = sub.add_parser("synth", help="render synthetic training panoramas (HDR, normals, albedo) with Mitsuba",
                        formatter_class=fmt,
                        description="Render N random rooms and outdoor scenes into 360-degree panoramas with "
                                    "normals and albedo, into a sharded, resumable dataset folder.",
                        epilog="examples:\n"
                               "  panolight synth --count 2000 --out data/synth                # 256x128, 64 spp\n"
                               "  panolight synth --count 2000 --out data/synth --shard 1/2 &  # two processes\n"
                               "  panolight synth --count 2000 --out data/synth --shard 2/2\n"
                               "  panolight sheet data/synth -o sheet.png                      # look at samples\n"
                               "Sample i is seeded by SEED + i, so re-runs skip finished samples and shards never "
                               "collide.")
    sy.add_argument("--count", type=int, required=True, help="number of samples (indices 0..count-1)")
    sy.add_argument("--out", required=True, help="dataset folder (created)")
    sy.add_argument("--resolution", type=resolution, default=(256, 128), help="panorama size WxH (default 256x128)")
    sy.add_argument("--spp", type=int, default=64,
                    help="samples per pixel (default 64: about 40 %% slower than 16 and far less noisy)")
    sy.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    sy.add_argument("--shard", help="render only shard I of N, written I/N")
    sy.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    sy.set_defaults(func=run_synth)

    sc = sub.add_parser("sheet", help="contact sheet of random dataset samples (LDR, normals, HDR, relit)",
                        formatter_class=fmt, description="Save a PNG contact sheet of random samples of a synthetic "
                                                         "dataset: LDR, normals, HDR and a relit version.")
    sc.add_argument("dataset", help="dataset folder written by 'panolight synth'")
    sc.add_argument("-o", "--output", default="sheet.png", help="PNG path (default sheet.png)")
    sc.add_argument("--count", type=int, default=6, help="samples shown (default 6)")
    sc.add_argument("--seed", type=int, default=0, help="which samples and lights (default 0)")
    sc.set_defaults(func=run_sheet)

    tr = sub.add_parser("train", help="train the learned estimator (paper: autoencoder, then lighting encoder)",
                        formatter_class=fmt,
                        description="Train the paper's two networks: the LDR-to-HDR autoencoder first, then the "
                                    "lighting encoder with it frozen. Data: procedural environments plus, with "
                                    "--data, Mitsuba panoramas from 'panolight synth' and their relit versions "
                                    "(paper Eq. 5), prepared once into a cached array file.",
                        epilog="examples:\n"
                               "  panolight train small --data data/synth --out runs/small --max-minutes 60\n"
                               "  panolight train small --procedural 500 --epochs 3 --out /tmp/try   # no Mitsuba data\n"
                               "  torchrun --nproc_per_node 4 -m training.neural.torchrun paper --data data/synth --out runs/paper\n"
                               "A run folder holds checkpoint.pt (resumed automatically), metrics.csv, "
                               "model.safetensors and config.json.")
    add_train_arguments(tr)
    tr.set_defaults(func=run_train)
    dev = sub.add_parser("dev", help="developer tools: model fits, studies and benchmarks ('panolight dev --help')",
                         formatter_class=fmt,
                         description="The developers' tools: fitting the shipped models, the studies behind them "
                                     "(docs/studies/) and the benchmarks. Each takes its own options: "
                                     "'panolight dev TOOL --help'.",
                         epilog="examples:\n"
                                "  panolight dev bench-sh                     # the SH engine against its peers\n"
                                "  panolight dev keylight-cv --help           # one tool's options\n"
                                "Each tool also runs as 'python -m MODULE' (the module its description names).")
    dev.set_defaults(func=lambda args: dev.print_help() or 2)
    tools = dev.add_subparsers(dest="tool", metavar="tool")
    for name, (module, text) in TOOLS.items():
        t = tools.add_parser(name, help=text, add_help=False, description=f"{text} (python -m {module})")
        t.set_defaults(func=run_tool, forward=True)


