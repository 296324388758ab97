"""``design``: search the calibration schedule a unit's table should run under a time budget (issue 29)."""

from __future__ import annotations

import argparse

from ..core.files import write_files
from ..data.problem import load_problem
from ..studies.design.criteria import CRITERIA
from .commands import CliError
from .logs import message_printer


def _angles(text: str) -> tuple[int, ...]:
    try:
        return tuple(sorted({int(a) for a in text.split(",") if a.strip()}))
    except ValueError:
        raise argparse.ArgumentTypeError(f"angles must be whole degrees separated by commas, found {text!r}") from None


def add_design_command(sub) -> None:
    """Register ``design`` with the command line's sub-parsers."""
    p = sub.add_parser("design", help="design a calibration schedule (positions, turns, dwell times) under a time "
                       "budget: design.toml, design.md, design.png")
    p.add_argument("problem", help="problem file: the unit, its noise and site, and the schedule to beat")
    p.add_argument("--total-s", type=float, required=True, help="time budget, s: statics + turns + handling")
    p.add_argument("--table-axes", type=int, choices=(1, 2, 3), default=3,
                   help="axes of the turntable: 3 turns about any body axis, 2 about the mount and a horizontal "
                   "(north) axis, 1 about the mount only (other positions need a new group) (default 3)")
    p.add_argument("--model", default="21", choices=["21", "extended"], help="parameter model (default 21)")
    p.add_argument("--criterion", default="d", choices=CRITERIA,
                   help="d: log det of the predicted covariance (natural units); a: its trace in units of the "
                   "input's variances; worst: the largest sigma ratio to the input; navigation: static "
                   "navigation error after --hours, or with --scheme the largest error of the modulated INS "
                   "(default d)")
    p.add_argument("--hours", type=float, default=1.0, help="navigation time of --criterion navigation, h (default 1)")
    p.add_argument("--scheme", metavar="NAME|FILE",
                   help="with --criterion navigation: the rotation scheme the unit runs in operation (a shipped "
                   "name such as dual-axis-16 or yu-ruan2014-improved, or a scheme file); the criterion is then "
                   "the largest position error of the modulated INS over --hours, as modulate --initial aligned "
                   "reports it with the problem's white noise")
    p.add_argument("--max-rate-deg-s", type=float, help="peak turn rate, deg/s (default: the input schedule's)")
    p.add_argument("--angles", type=_angles, default=(90, 180), help="turn angles allowed, deg (default 90,180)")
    p.add_argument("--min-rest-s", type=float, default=30.0, help="shortest static, s (default 30)")
    p.add_argument("--first-rest-s", type=float, default=60.0,
                   help="shortest first static of a group (its alignment), s (default 60)")
    p.add_argument("--handling-s", type=float, default=60.0,
                   help="time to handle the unit between groups, s; counts against --total-s (default 60)")
    p.add_argument("--cap", type=float, default=1.1,
                   help="a parameter's sigma above this times the input's is penalised (default 1.1)")
    p.add_argument("--evaluations", type=int, default=300,
                   help="orientation sequences scored by the search (default 300; each about 0.5 s)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the search (default 0)")
    p.add_argument("--verify", type=int, default=0, metavar="N",
                   help="Monte Carlo of the design: N simulated recordings (seeds from 10000, as montecarlo) "
                   "calibrated with both solvers; files in OUT/verify/")
    p.add_argument("--workers", type=int, help="local processes of the Monte Carlo (default one per core)")
    p.add_argument("--solvers", nargs="+", default=["nlp"], choices=["nlp", "ils"],
                   help="solvers whose predicted sigma the report gives: the search scores the NLP's (the default "
                   "solver); with ils also the paper's ILS's on both schedules (default nlp)")
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(func=cmd_design)


def cmd_design(args) -> int:
    """``design``: the search, then the files together."""
    from ..studies.design.run import default_rate, run_design  # the search loads only when it runs
    from ..studies.design.space import DesignError, Limits
    base = load_problem(args.problem)
    if args.evaluations < 1 or args.verify < 0 or not args.cap > 0 or not 0 < args.hours < float("inf"):
        raise CliError("--evaluations must be at least 1, --verify 0 or more, --cap and --hours positive")
    if args.verify:
        from ..studies.montecarlo import check_runs
        check_runs(args.verify, "--verify")
    from ..studies.budget import MAX_HOURS
    if args.hours > MAX_HOURS:
        raise CliError(f"--hours {args.hours:g} is beyond {MAX_HOURS:g} h: the navigation criterion is propagated at "
                       "every schedule the search scores (a calibration's worth is judged over hours to weeks)")
    if args.scheme and args.criterion != "navigation":
        raise CliError("--scheme goes with --criterion navigation (the navigation of the modulated INS)")
    scheme = None
    if args.scheme:
        from ..studies.modulation.schemes import load_scheme
        scheme = load_scheme(args.scheme)
    limits = Limits(total_s=args.total_s, max_rate_deg_s=default_rate(base) if args.max_rate_deg_s is None else args.max_rate_deg_s,
                    min_rest_s=args.min_rest_s, first_rest_s=args.first_rest_s, handling_s=args.handling_s,
                    angles=args.angles, table_axes=args.table_axes, profile=base.timing.rate_profile)
    try:
        result = run_design(base, limits, args.criterion, args.model, args.hours, args.cap, args.evaluations,
                            args.seed, args.verify, args.workers, args.out,
                            progress=message_printer(args, "design"), scheme=scheme, solvers=tuple(args.solvers))
    except DesignError as exc:
        raise CliError(str(exc)) from None
    write_files(result.files)
    score = result.best.score
    for group in result.problem.groups:
        print(f"group {group.start}: {' '.join(r.replace(' ', '/') for r in group.rotations)}; statics "
              f"{', '.join(f'{s:g}' for s in group.statics_s)} s")
    turns = sorted({(abs(s.angle_deg), round(s.end - s.start, 3)) for s in result.problem.segments()
                    if s.kind == "rotation"})
    print(f"turns {', '.join(f'{a:g} deg in {t:g} s' for a, t in turns)}; total {result.problem.duration:.0f} s")
    print(f"predicted sigma (nlp) against {base.name}: geometric mean {score.geometric_mean:.3f}, worst "
          f"{score.ratios.max():.3f}; criterion {args.criterion} {score.value:+.4f}")
    if result.ils is not None:
        import numpy as np
        ratio = result.ils["design"] / result.ils["input"]
        print(f"predicted sigma (ils) against {base.name}: geometric mean {float(np.exp(np.mean(np.log(ratio)))):.3f}, "
              f"worst {ratio.max():.3f}")
    if result.verify is not None:
        for solver, s in result.verify.groupby("solver", sort=False):
            print(f"Monte Carlo {solver}: RMS error / sigma {s['rms_over_sigma'].min():.2f}-"
                  f"{s['rms_over_sigma'].max():.2f}, / predicted {s['rms_over_predicted'].min():.2f}-"
                  f"{s['rms_over_predicted'].max():.2f}")
        for check in result.checks:
            print(f"  {check.line()}")
    print(f"wrote {args.out}/design.toml, design.md, design.png ({result.seconds:.0f} s)")
    return 0
