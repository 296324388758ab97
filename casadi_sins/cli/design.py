"""``design``: search the calibration schedule a unit's table should run under a time budget (issue 29)."""

from __future__ import annotations

from ..core.files import write_files
from ..data.problem import load_problem
from .commands import CliError
from .logs import message_printer


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
