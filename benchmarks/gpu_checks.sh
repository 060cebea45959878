#!/usr/bin/env bash
# The GPU checks and measurements issue 38 asks for, in one run (a machine with an NVIDIA GPU and the
# gpu extra; docs/batched.md). Everything goes to OUT (default gpu_checks/): the CUDA tests' log, one
# CSV per benchmark row, the planner's table and the training folders; each stage has its own time
# limit, so a stage that hangs or compiles too long does not take the rest with it.
#
#   bash benchmarks/gpu_checks.sh [OUT]
#
# Stages (seconds each; set in the environment): TESTS_S=300 BENCH_S=240 PLANNER_S=120 TRAIN_S=0
# (TRAIN_S > 0 trains `search` with PPO on the batched engine for seeds SEEDS="0 1 2", TIMESTEPS each,
# default 4000000: ppo_batched.yml's budget).
set -u
OUT=${1:-gpu_checks}
mkdir -p "$OUT"
TESTS_S=${TESTS_S:-300} BENCH_S=${BENCH_S:-240} PLANNER_S=${PLANNER_S:-120} TRAIN_S=${TRAIN_S:-0}
SEEDS=${SEEDS:-0 1 2} TIMESTEPS=${TIMESTEPS:-4000000}
export PYTHONUNBUFFERED=1
CODE=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
t0=$(date +%s)
stage() { echo "=== [$(($(date +%s) - t0)) s] $*"; }

stage "CUDA tests (the first run compiles Warp's kernels)"
CONFORMAL_TEST_DEVICE=cuda timeout "$TESTS_S" python -m pytest -n 0 -p no:cacheprovider -q \
    tests/test_batched_physics.py tests/test_batched_env.py tests/test_batched_vision.py tests/test_retina_rays.py \
    >"$OUT/cuda_tests.txt" 2>&1
echo "rc=$?"; tail -5 "$OUT/cuda_tests.txt"

# the physics three ways, the fused kernel first (new; the other two have rows from earlier runs): MuJoCo
# Warp stepped every millisecond, and with the settle in closed form
for physics in fused stepped tail; do
    for eyes in pictures rays; do
        label="${eyes}_${physics}"
        stage "benchmark: $label"
        extra=()
        [ "$eyes" = rays ] && extra=(--retina-rays 1)
        case $physics in
            fused) extra+=(--fused on --linear-tail off) ;;
            stepped) extra+=(--fused off --linear-tail off) ;;
            tail) extra+=(--fused off --linear-tail on) ;;
        esac
        timeout "$BENCH_S" python benchmarks/batched.py --device cuda --num-envs 4096 --steps 8 --single-steps 5 \
            "${extra[@]}" --csv "$OUT/bench_$label.csv" --label "main $CODE, $label" \
            2>&1 | grep -v "load on device"
        echo "rc=${PIPESTATUS[0]}"
    done
done

stage "physics replayed three ways, beside MuJoCo C"
timeout "$BENCH_S" python benchmarks/physics.py --device cuda --num-envs 4096 --steps 4 --reference-worlds 16 \
    >"$OUT/physics.txt" 2>&1
echo "rc=$?"; grep -v "load on device" "$OUT/physics.txt" | tail -8

stage "host planner"
timeout "$PLANNER_S" python benchmarks/planner.py --num-envs 4096 --steps 3 >"$OUT/planner.txt" 2>&1
echo "rc=$?"; cat "$OUT/planner.txt"

if [ "$TRAIN_S" -gt 0 ]; then
    for seed in $SEEDS; do
        stage "train search, seed $seed"
        timeout -s INT "$TRAIN_S" python -m experiments train --algo ppo --engine batched --device cuda \
            --task search --seed "$seed" --timesteps "$TIMESTEPS" --out "$OUT/search_seed$seed" 2>&1 | tail -5
        echo "rc=${PIPESTATUS[0]}"
    done
fi
stage done
