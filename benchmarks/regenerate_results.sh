#!/usr/bin/env bash
# Regenerate everything in results/ (CSV, Markdown, PNG) with one command: bash benchmarks/regenerate_results.sh
# About 90 minutes on a 2-core machine (the noise Monte Carlo is 40 of them).  Each step prints its figures;
# the printed outputs go to results/*.txt.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-results}
mkdir -p "$out"
casadi-sins demo --out "$out"                                                  # compare, navcheck, budget
casadi-sins analyze problems/kang2013.toml problems/xie2011-19pos.toml --out "$out"   # predicted sigma
casadi-sins montecarlo --runs 50 --out "$out"                                  # RMS against predicted sigma
python benchmarks/bench_noise.py --runs 50 --no-datasheet --out "$out" | tee "$out/noise-benchmark.txt"
python benchmarks/bench_quantization.py --runs 20 --out "$out" | tee "$out/quantization-benchmark.txt"   # coarse pulse counter (issue 16)
python benchmarks/bench_extended.py --runs 30 --out "$out" | tee "$out/extended-benchmark.txt"
python benchmarks/bench_phases.py --out "$out" | tee "$out/main-job-phases.txt"
python benchmarks/bench_speed.py --out "$out" | tee "$out/speed.txt"             # whole processes, one core (issue 18)
python benchmarks/bench_long.py --out "$out" | tee "$out/long-file.txt"
python benchmarks/bench_nlp.py --seeds 50 --out "$out" | tee "$out/nlp-benchmark.txt"
python benchmarks/bench_ils.py --seeds 20 --out "$out" | tee "$out/ils-benchmark.txt"
python benchmarks/sweep_start_attitude.py --seeds 8 --solvers nlp ils --out "$out"
python benchmarks/bench_budget.py --runs 24 --out "$out"
python benchmarks/bench_navigation.py | tee "$out/navigation-timing.txt"
python benchmarks/bench_montecarlo.py --runs 100 | tee "$out/montecarlo-throughput.txt"
python benchmarks/bench_modulation.py --out "$out/modulation"                # rotation modulation (issue 19), ~4 min
python benchmarks/bench_modulation_design.py --out "$out/modulation"         # start phase, the factor 2, design-scheme (issue 27), ~2 min
python benchmarks/bench_segmentation.py --seeds 3 --out "$out"                 # segment edges next to slow handling
python benchmarks/bench_hand.py --runs 3 --out "$out"                          # sessions by hand, IMU-TK's session (issue 37), ~10 min
python benchmarks/bench_edges.py --runs 50 --out "$out" | tee "$out/edges-benchmark.txt"   # issue 16's worlds, no datasheet
python benchmarks/bench_batch.py --units 12 --out "$out" | tee "$out/batch-dask.txt"       # Dask: 1 worker against 2
python benchmarks/bench_mutations.py --seeds 250 --toml-seeds 30 --hostile-seeds 160 --outputs-seeds 160 --child-seeds 40 --out "$out"  # hostile input (issues 17, 24, 35): 5,501 cases, about an hour
python benchmarks/bench_thermal.py --seeds 1 2 3 --out "$out" | tee "$out/thermal-benchmark.txt"   # thermal model, a setpoint left out (issue 30), ~6 min
casadi-sins design problems/kang2013.toml --total-s 1290 --verify 20 --out "$out/design-kang2013"           # schedule design (issue 29)
casadi-sins design problems/kang2013.toml --total-s 1290 --criterion navigation --scheme dual-axis-16 --hours 24 --verify 20 --out "$out/design-kang2013-dual-axis-16"   # designed for a modulated INS
casadi-sins design problems/kang2013.toml --total-s 1290 --seed 1 --out "$out/design-kang2013-seed1"   # another search seed
casadi-sins design problems/kang2013.toml --total-s 1290 --angles 90 --out "$out/design-kang2013-angles90"   # 90 deg turns only
casadi-sins analyze "$out/design-kang2013/design.toml" problems/kang2013.toml --out "$out/design-kang2013/analyze"   # the bar's analyze
casadi-sins montecarlo "$out/design-kang2013/design.toml" --runs 200 --first-seed 20000 --solvers nlp --out "$out/design-kang2013/verify-200"   # what 200 runs settle
python benchmarks/bench_design.py --budgets 20 60 300 --out "$out" | tee "$out/design-benchmark.txt"            # search budget against quality
