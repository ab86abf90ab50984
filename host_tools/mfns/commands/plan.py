"""`mfns plan`: beacon-layout planning -- analyse a map, optimise a layout (mfns.plan)."""

from __future__ import annotations

from ..core import study
from ..plan import run
from ..simulate import module_geom


def _common(p) -> None:
    p.add_argument("out", metavar="OUT", help="output folder (created; files in it are overwritten)")
    p.add_argument("--rig", help="calibration-results JSON of the rig (default: the paper's, Tables 2-3)")
    w = p.add_argument_group("workspace (docs/planning.md)")
    w.add_argument(
        "--workspace",
        choices=("turntable", "module", "box", "truth"),
        default="turntable",
        help="pose samples: the turntable's sweep, the module's interior (the demo's, or "
        "--module-size), a --box, or the poses of a --truth file (default turntable)",
    )
    module_geom.add_arguments(
        w, "--workspace module samples its path's box, --surfaces module puts beacons on its walls"
    )
    w.add_argument("--truth", metavar="CSV", help="truth: the poses of a truth.csv (mfns sim nav), in order")
    w.add_argument("--samples", type=int, default=200, help="pose samples (default 200)")
    w.add_argument("--yaw-start", type=float, default=0.0, help="turntable: first yaw, deg (default 0)")
    w.add_argument("--yaw-span", type=float, default=120.0, help="turntable: yaw swept, deg (default 120)")
    w.add_argument(
        "--box",
        metavar="X0,Y0,Z0,X1,Y1,Z1",
        help="box: position range of the body origin, mm (write --box=-X0,... for negative values)",
    )
    for k in ("roll", "pitch", "yaw"):
        w.add_argument(f"--{k}", metavar="LO,HI", help=f"box: {k} range, deg (default: uniform attitude)")
    n = p.add_argument_group("noise model of the Cramer-Rao bound")
    n.add_argument(
        "--pixel-sigma", type=float, help="centroid noise 1-sigma, px (default: the rig's pixel_noise_px)"
    )
    n.add_argument("--beacon-sigma", type=float, help="survey 1-sigma of every beacon, mm (0: exact map)")
    n.add_argument(
        "--no-calib-sigma", action="store_true", help="ignore the rig's calibration 1-sigma entries"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (pose samples, optimiser) (default 0)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "plan", help="beacon-layout planning: coverage, 1-sigma, optimised layouts"
    )
    sub = parser.add_subparsers(dest="plan_command", metavar="ACTION")
    a = sub.add_parser(
        "analyze",
        help="beacons in view, fix availability and Cramer-Rao 1-sigma of a map over a workspace",
        description="Per pose sample: beacons in view per camera (the C core's decision), whether a fix "
        "is possible, the Cramer-Rao 1-sigma of the pose; writes samples.csv, summary.{json,md} and "
        "in_view_hist.png, availability.png, sigma.png into OUT.",
    )
    _common(a)
    a.add_argument(
        "--no-ident-margin",
        action="store_true",
        help="skip the identification margin (the acquisition's map analysis per sample, ~50 ms each)",
    )
    a.add_argument(
        "--beacons", help="beacons.csv (id,x_mm,y_mm,z_mm,sigma_mm) (default: the paper's Table 4)"
    )
    a.set_defaults(func=run.run_analyze)
    o = sub.add_parser(
        "optimize",
        help="place N beacons on candidate surfaces: availability first, then worst-case 1-sigma",
        description="Greedy construction then simulated annealing over grid candidates on the surfaces; "
        "writes OUT/beacons.csv (the format mfns sim nav --beacon-map and mfns table build read), "
        "plan.json (algorithm, run time, objective) and the analysis of the result on independent samples.",
    )
    _common(o)
    o.add_argument(
        "--surfaces", default="paper-frame", help="paper-frame, module or a JSON file (default paper-frame)"
    )
    o.add_argument("--count", type=int, default=10, help="number of beacons (default 10)")
    o.add_argument(
        "--min-spacing", type=float, default=100.0, help="minimum beacon spacing, mm (default 100)"
    )
    o.add_argument(
        "--keep-out", action="append", metavar="X0,Y0,Z0,X1,Y1,Z1", help="box with no beacon (repeatable)"
    )
    o.add_argument(
        "--grid", type=float, default=40.0, help="candidate grid spacing on the surfaces, mm (default 40)"
    )
    o.add_argument("--iterations", type=int, default=8000, help="annealing moves per restart (default 8000)")
    o.add_argument(
        "--margin",
        type=int,
        default=0,
        help="optimise for 4 + MARGIN beacons in view: a reserve for poses between the samples (default 0)",
    )
    o.add_argument(
        "--cert-in-view",
        type=int,
        default=None,
        help="beacons in view that count as certifiable in one call (default 5 + MARGIN); "
        "measured one-call rates by beacons in view: docs/planning.md",
    )
    o.add_argument("--restarts", type=int, default=3, help="independent runs, the best kept (default 3)")
    o.add_argument(
        "--baseline",
        help="beacons.csv to compare with (analysed on the same samples; "
        "its sigma_mm is the default survey sigma)",
    )
    o.add_argument(
        "--no-certify",
        action="store_true",
        help="leave certifiable one-call acquisition (>= 5 beacons in view, fewest ambiguous views) "
        "out of the objective",
    )
    o.add_argument(
        "--ident-samples",
        type=int,
        default=100,
        help="views the map analysis checks per restart for ambiguity (~50 ms each; 0: none) (default 100)",
    )
    o.add_argument(
        "--polish",
        type=int,
        default=2000,
        help="moves of the final hill climb on the flight's own verdict (C solver + integrity per "
        "view: usable, then usable in one call), 0: none (default 2000)",
    )
    o.add_argument(
        "--fly-frames",
        type=int,
        default=120,
        help="fly check: frames per fresh module path flown by mfns sim nav + the flight program "
        "before the plan is reported (0: no fly check) (default 120)",
    )
    o.add_argument("--fly-paths", type=int, default=2, help="fly check: fresh paths per layout (default 2)")
    o.add_argument(
        "--fly-starts",
        type=int,
        default=20,
        help="fly check: lost starts per path for the measured one-call rate: the flight program "
        "started afresh at this many frames spread over the path, one cycle each; a start counts "
        "when its first cycle certifies a fix (0: none) (default 20)",
    )
    study.add_arguments(o)  # where the fly check's flights run (docs/studies.md)
    o.set_defaults(func=run.run_optimize)
    z = sub.add_parser(
        "size",
        help="how many LEDs a module needs: the curve LED count -> usable and one-call rates",
        description="For each --counts, plan a layout on the surfaces (greedy + annealing) and judge it "
        "by the flight's own verdict (the C solver and integrity per view) on independent samples; "
        "writes size.json, size.csv, size.png and beacons_<N>.csv into OUT, prints the smallest count "
        "reaching the targets and what each smaller count cannot reach.",
    )
    _common(z)
    z.add_argument("--surfaces", default="module", help="paper-frame, module or a JSON file (default module)")
    z.add_argument(
        "--counts", default="12,24,36,48,60,90", help="LED counts to try (default 12,24,36,48,60,90)"
    )
    z.add_argument("--target-usable", type=float, help="target usable rate, %% of workspace poses")
    z.add_argument("--target-one-call", type=float, help="target one-call acquisition rate, %%")
    z.add_argument(
        "--grid", type=float, default=100.0, help="candidate grid spacing on the surfaces, mm (default 100)"
    )
    z.add_argument(
        "--min-spacing", type=float, default=150.0, help="minimum beacon spacing, mm (default 150)"
    )
    z.add_argument(
        "--keep-out", action="append", metavar="X0,Y0,Z0,X1,Y1,Z1", help="box with no beacon (repeatable)"
    )
    z.add_argument("--iterations", type=int, default=1500, help="annealing moves per count (default 1500)")
    z.add_argument(
        "--margin", type=int, default=1, help="optimise for 4 + MARGIN beacons in view (default 1)"
    )
    z.add_argument(
        "--polish",
        type=int,
        default=1000,
        help="moves per count of the hill climb on the flight's own verdict (as plan optimize), "
        "0: none (default 1000)",
    )
    z.set_defaults(func=run.run_size)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)
