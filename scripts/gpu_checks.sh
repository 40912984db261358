#!/bin/bash
# The checks that need the GPU machine, in one run, each step cut off at its own time limit:
#   separated  converged Mitsuba references (llvm_ad_rgb on the 16 CPU cores) of the heads whose fibers
#              do not overlap (scripts/separated_heads.py);
#   held_out   references of the held-out heads (scripts/held_out_heads.py);
#   scaling    thread scaling (scripts/thread_scaling.py);
#   equal      Mitsuba cuda_ad_rgb at each preset's error (scripts/mitsuba_equal_error.py);
#   before     the frame at 16 threads with an earlier wheel (.dev/before.whl, a `maturin build` of an
#              earlier commit) and a later one (.dev/after.whl; without it, the site's), alternated in
#              BEFORE_RUNS (3) processes each (docs/scaling_ab.csv, summarized in docs/scaling_ab.md);
#   refs       llvm_ad_rgb references of the held-out heads REF_HEADS at 2 x REF_SPP spp, seeds REF_SEEDS,
#              the strands traced as REF_CURVE (bspline, as the cached NAME.exr; polyline: NAME_polyline.exr).
# STEPS picks them (default: separated scaling equal).
#
# Before, here: ../shared/tools/gpu_site.sh (packs Mitsuba, drjit and this checkout's wheel into .dev/)
# and cp ../shared/references/demo_head_640.exr .dev/. Then, on the GPU machine, from the project root
# (carry .dev):  bash scripts/gpu_checks.sh
# Writes $OUT/log.txt and $OUT/results.tar (docs/equal_error*, docs/scaling*, the references written),
# packed again after each step so that a step cut short keeps the ones before it.
# The working tree and .dev travel together under a 64 MiB limit: the site pack is ~30 MB with the Mitsuba
# plugins hairshade never loads removed (ellipsoids*, volpath*, sdfgrid, sunsky, timed_sunsky, ptracer,
# principled*, measured*, rough*, pplastic, aov, disk, rectangle, cylinder); where that is not enough, move
# aside for the call the test data its steps do not read (separated reads tests/data/separated alone).
set -u
out=${OUT:-/tmp/gpu_checks}
mkdir -p "$out" /tmp/site /tmp/held
if [ "${SITE:-1}" = 1 ]; then  # SITE=0: use the Python environment as it is (a dry run here, with PY)
  tar xJf .dev/site.tar.xz -C /tmp/site && export PYTHONPATH=/tmp/site
fi
export PYTHONUNBUFFERED=1
py=${PY:-python3}
variant=${VARIANT:-cuda_ad_rgb}
pack() {
  tar cf "$out/results.tar" docs/equal_error* docs/scaling* $(ls /tmp/held/*.exr 2>/dev/null | sed 's|/tmp/held|tests/data/held_out|') \
    tests/data/separated/*.exr tests/data/separated/*.txt 2>/dev/null
}
held_out() {  # held_out SPP SECONDS HEADS
  timeout "$2" $py scripts/held_out_heads.py /tmp/held --spp "$1" --depth2-spp "${D2_SPP:-1024}" --variant llvm_ad_rgb \
    --heads "$3"
  cp /tmp/held/*.exr tests/data/held_out/ 2>/dev/null
  pack
}
{
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
  lscpu | grep -E 'Model name|^CPU\(s\)'
  $py -c "import hairshade as hs, mitsuba as mi; print(hs.__version__, hs._native.simd_level(), mi.__version__)"
  for step in ${STEPS:-separated scaling equal}; do
    echo "== $step $(date +%T)"
    case $step in
      separated)
        rm -f tests/data/separated/*.txt
        timeout ${SEPARATED_S:-200} $py scripts/separated_heads.py --reference ${SEP_SPP:-2048} --depth2 ${SEP_D2_SPP:-512} \
          --heads sep_straight_blond_back,sep_wavy_blond_rim,sep_curly_blond_point,sep_straight_brown_key ;;
      held_out)
        held_out ${SPP:-4096} ${REFS_S:-90} curly_auburn_point,wavy_black_env,wavy_ginger_back,straight_brown_back
        held_out ${BLOND_SPP:-16384} ${BLOND_S:-120} clumped_blond_key,curly_blond_env,wavy_blond_rim ;;
      scaling)
        timeout ${SCALING_S:-200} $py scripts/thread_scaling.py --threads ${THREADS:-1,16,8,4,2} --size ${SIZE:-1280x720} --repeats ${REPEATS:-2} ;;
      equal)
        timeout ${EQUAL_S:-180} $py scripts/mitsuba_equal_error.py --variant "$variant" --max-spp ${MAX_SPP:-1024} \
          --demo-truth .dev/demo_head_640.exr ;;
      before)
        # builds alternated (before, after; after, before; ...), BEFORE_RUNS processes each
        mkdir -p /tmp/before /tmp/after /tmp/ab && $py -m zipfile -e .dev/before.whl /tmp/before
        if [ -f .dev/after.whl ]; then $py -m zipfile -e .dev/after.whl /tmp/after; fi
        for k in $(seq ${BEFORE_RUNS:-3}); do
          if [ $((k % 2)) = 0 ]; then order="after before"; else order="before after"; fi
          for b in $order; do
            PYTHONPATH=/tmp/$b:${PYTHONPATH:-} timeout ${BEFORE_S:-70} $py scripts/thread_scaling.py --threads 16 \
              --repeats ${BEFORE_REPEATS:-2} --out /tmp/ab --name ${b}_$k
          done
        done
        for f in /tmp/ab/*.csv; do sed "s/^/$(basename $f .csv),/" $f; done > docs/scaling_ab.csv
        $py scripts/thread_scaling.py --ab docs/scaling_ab.csv ;;  # (on that machine: its CPU named)
      refs)
        timeout ${REFS_S:-240} $py scripts/held_out_heads.py /tmp/held --spp ${REF_SPP:-4096} --seeds ${REF_SEEDS:-23,24} \
          --variant llvm_ad_rgb --heads ${REF_HEADS:-curly_blond_env} --curve ${REF_CURVE:-bspline}
        cp /tmp/held/*.exr tests/data/held_out/ 2>/dev/null ;;
    esac
    pack
  done
  echo "== done $(date +%T)"
} 2>&1 | tee "$out/log.txt"
