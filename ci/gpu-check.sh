#!/usr/bin/env bash
# The standing GPU check: vkmech on a real GPU machine that has a Vulkan
# driver but none of our Debian packages (the lent NVIDIA machines).
#
#   bash ci/gpu-check.sh stage        # here, after building: copies the binaries,
#                                     # their shared libraries, the Vulkan loader and
#                                     # the validation layer into .gpu/ (git-ignored)
#   bash ci/gpu-check.sh run [WHAT]   # there, from the repository root: runs
#                                     # WHAT (default: all) and writes logs to $OUT
#   bash ci/gpu-check.sh bisect-stage [COMMIT...]
#                                     # here: builds vkmech at each commit (default:
#                                     # 3631bde, every later commit that changed shaders/,
#                                     # HEAD; `worktree`: the current build; `bin:NAME`: a
#                                     # variant in build-bisect/bin/NAME/; `env:NAME:VAR=VALUE`: the current
#                                     # build run with VAR=VALUE) and packs the binaries with their scenes
#                                     # into .gpu/bisect.tar.xz (run `stage` too)
#   bash ci/gpu-check.sh run bisect [--plan]
#                                     # there: `bench render --res 512 --spp 64` of every
#                                     # staged binary, rounds alternating, one table;
#                                     # --plan (here too) prints what it would run and
#                                     # its estimated time
#
# WHAT is a comma-separated list of: devices, tests (the GPU suite, then the CPU suites),
# gpu-tests (the GPU suite alone), envmap (the validation scene lit by its sky map, then by
# the paper's panel, each kernel), bench, main, pipeline-cache, study-quick,
# cornell (the Cornell box of ci/scenes at 1024^2 x 64 spp, each kernel), profile, ablation, bisect,
# paper (the paper preset of every study, as far as PAPER_BUDGET_S allows), threshold (a
# noise-threshold render and uniform sampling at its samples), taxonomy (renders with the buckets, paper.lpe, --lpe
# queries and an example taxonomy: what a taxonomy costs).
# Results go to docs/gpu.md by hand, with the device, driver and date.
set -uo pipefail
cd "$(dirname "$0")/.."
root=$PWD

stage() {
    local build=${BUILD_DIR:-build}
    [[ -x $build/vkmech && -x $build/vkmech_tests ]] || { echo "gpu-check: build first ($build/vkmech)"; exit 2; }
    # .gpu/bisect.tar.xz (bisect-stage) stays.
    rm -rf .gpu/bin .gpu/lib .gpu/lib-fallback .gpu/layers .gpu/source_dir
    mkdir -p .gpu/bin .gpu/lib .gpu/lib-fallback .gpu/layers
    cp "$build/vkmech" "$build/vkmech_tests" .gpu/bin/
    # Every shared library the binaries need except the C runtime, which the
    # target machine has (a newer glibc runs binaries built against 2.36). The
    # C++ runtime and zlib go aside: a newer system copy is preferred there,
    # since python3 (the study's plots) inherits LD_LIBRARY_PATH.
    local libs
    libs=$(ldd "$build/vkmech" "$build/vkmech_tests" | awk '/=> \//{print $3}' | sort -u |
        grep -Ev '/(libc|libm|libdl|libpthread|librt|ld-linux[^/]*)\.so')
    for l in $libs; do
        case $(basename "$l") in
            libstdc++*|libgcc_s*|libz.so*) cp -L "$l" .gpu/lib-fallback/ ;;
            *) cp -L "$l" .gpu/lib/ ;;
        esac
    done
    # The Khronos validation layer, so the GPU suites run validated there too.
    local layer=/usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so
    if [[ -f $layer ]]; then
        cp -L "$layer" .gpu/lib/
        sed 's#"library_path": *"[^"]*"#"library_path": "../lib/libVkLayer_khronos_validation.so"#' \
            /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json >.gpu/layers/VkLayer_khronos_validation.json
    fi
    # The binaries find scenes/, docs/ and analysis/ under the source directory
    # they were built from; the run step links that path to its own checkout.
    sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt" >.gpu/source_dir
    # The tests run the CLI by the path it was built at (VKMECH_CLI): the run step links that
    # build directory to its own build/.
    (cd "$build" && pwd) >.gpu/build_dir
    # The largest files travel compressed (the run's tree is limited to 64 MiB); the run step
    # unpacks them.
    local big
    for big in .gpu/bin/vkmech_tests .gpu/lib/libVkLayer_khronos_validation.so; do
        [[ -f $big ]] && { xz -T0 -6 -f "$big" || { echo "gpu-check: stage: cannot pack $big with xz"; exit 2; }; }
    done
    # The Vulkan loader and the GL vendor-neutral dispatch libraries as Debian
    # packages: the NVIDIA ICD (libGLX_nvidia.so.0) needs libGLdispatch, which
    # the target image lacks.
    mkdir -p .gl /tmp/amd64/partial
    local pkgs=(libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2) missing=() p
    for p in "${pkgs[@]}"; do ls .gl/"${p}"_*.deb >/dev/null 2>&1 || missing+=("$p"); done
    if ((${#missing[@]})); then
        local o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
        apt-get $o update -qq && (cd .gl && apt-get $o download "${missing[@]}")
    fi
    du -sh .gpu .gl
    echo "gpu-check: staged; run there with carry [.gpu, .gl]: bash ci/gpu-check.sh run"
}

section() { printf '\n===== %s (%s) =====\n' "$1" "$(date -u +%H:%M:%S)"; }
timed() {  # timed LABEL CMD...: runs CMD, prints its wall time and exit code
    local label=$1; shift
    local t0 t1 rc
    t0=$(date +%s.%N)
    "$@"
    rc=$?
    t1=$(date +%s.%N)
    printf 'gpu-check: %s: exit %d, %.2f s wall\n' "$label" "$rc" "$(echo "$t1 - $t0" | bc -l 2>/dev/null || python3 -c "print($t1-$t0)")"
    return $rc
}

# The device machine's environment: Debian's loader and GL dispatch unpacked,
# the staged libraries first on the path, the NVIDIA ICD and the validation layer.
device_env() {
    [[ -d .gpu/bin ]] || { echo "gpu-check: no .gpu/ here: run 'bash ci/gpu-check.sh stage' and carry .gpu and .gl"; exit 2; }
    local f
    if compgen -G '.gpu/*/*.xz' >/dev/null; then
        command -v xz >/dev/null || { echo "gpu-check: the staged files are packed with xz, which this machine lacks"; exit 2; }
        for f in .gpu/bin/*.xz .gpu/lib/*.xz; do [[ -f $f ]] && xz -d -f "$f"; done
    fi
    chmod +x .gpu/bin/*
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
    export LD_LIBRARY_PATH=$root/.gpu/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
    if ldd .gpu/bin/vkmech_tests | grep -q 'not found'; then
        export LD_LIBRARY_PATH=$LD_LIBRARY_PATH:$root/.gpu/lib-fallback
    fi
    export VK_LAYER_PATH=$root/.gpu/layers
    # The NVIDIA driver's ICD manifest lives outside the loader's search path
    # on these machines.
    local icd
    for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json \
               /etc/vulkan/icd.d/nvidia_icd.json; do
        if [[ -f $icd ]]; then export VK_DRIVER_FILES=$icd VK_ICD_FILENAMES=$icd; break; fi
    done
    export VKMECH_REQUIRE_GPU=1  # the GPU suites fail, not skip, without a device
    local src
    src=$(cat .gpu/source_dir)
    if [[ -n $src && $src != "$root" && ! -e $src ]]; then mkdir -p "$(dirname "$src")" && ln -s "$root" "$src"; fi
    mkdir -p build && cp .gpu/bin/vkmech .gpu/bin/vkmech_tests build/
    local bld
    bld=$(cat .gpu/build_dir 2>/dev/null)
    if [[ -n $bld && $bld != "$root/build" && ! -e $bld ]]; then mkdir -p "$(dirname "$bld")" && ln -sfn "$root/build" "$bld"; fi
}

# The GPU suite in $1 processes at once, each bounded by $2 seconds; each
# shard's log in $3/gpu-tests-<k>.log, printed after the summary; fails if any shard fails.
gpu_suite_sharded() {
    local shards=$1 limit=$2 dir=$3 n per k rc=0
    # The slowest case (GPU_TEST_SOLO; 93 s of the 111 s on the H200 on 2026-11-26) runs
    # alone in one more process, the rest in ranges by name.
    local solo=${GPU_TEST_SOLO:-study: vkmech study all --preset quick*}
    n=$("$root/build/vkmech_tests" -ts=gpu -tce="$solo" -ltc | grep -cv '^\[doctest\]\|^=\|^$')
    per=$(((n + shards - 1) / shards))
    echo "gpu-check: $n GPU test cases in $shards shards of up to $per, and '$solo' alone"
    timeout -s INT "$limit" "$root/build/vkmech_tests" -ts=gpu -tc="$solo" -d >"$dir/gpu-tests-solo.log" 2>&1 &
    for ((k = 0; k < shards; ++k)); do
        timeout -s INT "$limit" "$root/build/vkmech_tests" -ts=gpu -tce="$solo" -ob=name -d \
            --first=$((k * per + 1)) --last=$(((k + 1) * per)) >"$dir/gpu-tests-$k.log" 2>&1 &
    done
    for ((k = 0; k <= shards; ++k)); do wait -n || rc=1; done
    # (doctest counts the cases outside --first..--last as passed: count the timed ones.)
    echo "gpu-check: $(cat "$dir"/gpu-tests-*.log | grep -c -E '^[0-9]+\.[0-9]+ s: ') cases ran;" \
        "$(grep -l 'Status: SUCCESS' "$dir"/gpu-tests-*.log | wc -l) of $((shards + 1)) processes succeeded"
    grep -h -E 'ERROR|FATAL' -A4 "$dir"/gpu-tests-*.log | head -60
    # The slowest cases (doctest -d prints each case's seconds before its name).
    grep -h -E '^[0-9]+\.[0-9]+ s: ' "$dir"/gpu-tests-*.log | sort -rn | head -12
    # Where the solo case's time went: its study prints each phase, and the case passes them on as MESSAGEs.
    grep -h 'MESSAGE' "$dir"/gpu-tests-solo.log | cut -c1-1500
    echo "gpu-check: the shards' whole logs:"
    cat "$dir"/gpu-tests-*.log
    return $rc
}

run() {
    local what=${1:-all}
    if [[ ,$what, == *,bisect,* && ${2:-} == --plan ]]; then bisect_plan; return; fi
    local out=${OUT:-$root/out/gpu-check}
    mkdir -p "$out"
    device_env
    local vk=$root/build/vkmech

    {
        section "machine"
        date -u '+%Y-%m-%d %H:%M:%S UTC'
        nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>&1
        nproc; uname -r
        echo "ICD: ${VK_DRIVER_FILES:-none found}"; ls /usr/share/vulkan/icd.d /etc/vulkan/icd.d 2>&1
        [[ -n ${VK_DRIVER_FILES:-} ]] && cat "$VK_DRIVER_FILES"
        has() { [[ ,$what, == *,all,* || ,$what, == *,$1,* ]]; }
        if has devices; then
            section "vkmech devices"
            timed devices "$vk" devices
        fi
        if has tests || has gpu-tests; then
            section "GPU test suites (vkmech_tests -ts=gpu)"
            # Bounded, so that a case that runs away on a large device cannot eat the lease;
            # in GPU_TEST_SHARDS processes at once (doctest --first/--last over the suite's
            # cases by name): a fresh machine's time goes to the driver compiling
            # pipelines, on the CPU, one core per process. Each case's time (-d) is logged.
            rm -rf out/gpu-tests && mkdir -p out/gpu-tests
            timed "gpu tests" gpu_suite_sharded "${GPU_TEST_SHARDS:-8}" "${GPU_TESTS_TIMEOUT_S:-240}" out/gpu-tests
            if has tests; then
                section "CPU test suites"
                timed "cpu tests" "$root/build/vkmech_tests" -tse=gpu
            fi
        fi
        if has bench; then
            section "vkmech bench traversal (defaults: 2^18 rays)"
            timed "bench traversal" "$vk" bench traversal
            section "vkmech bench traversal --rays 4194304"
            timed "bench traversal 4M" "$vk" bench traversal --rays 4194304
            # The ray kernel's slices, off on GPUs by default until measured on one:
            # the bvh column with them, against the one-ray-per-invocation column.
            section "vkmech bench traversal --kernel cpu --bvh-only --slices --rays 4194304"
            timed "bench traversal slices" "$vk" bench traversal --kernel cpu --bvh-only --slices --rays 4194304
            section "vkmech bench render (defaults: 128^2, 8 spp)"
            timed "bench render" "$vk" bench render
            section "vkmech bench render --res 512 --spp 64"
            timed "bench render 512" "$vk" bench render --res 512 --spp 64
            # Where the path tracer's time goes on this device, by the shader's clock.
            section "vkmech bench render --profile --counters --res 512 --spp 16 --batches 16"
            timed "bench render phases" "$vk" bench render --profile --counters --res 512 --spp 16 --batches 16
        fi
        if has threshold; then
            # The noise threshold's rounds on a GPU (descriptor §6.8), and uniform sampling at the
            # samples per pixel the threshold took, for their seconds side by side.
            section "noise threshold: glass_caustic at 512 px, T 0.05, max 1024 spp"
            rm -rf out/nt_glass
            timed "noise threshold" "$vk" render --scene glass_caustic --res 512 --noise-threshold 0.05 \
                --max-spp 1024 --out out/nt_glass
            cp out/nt_glass/glass_caustic.json "$out/noise_threshold_glass_caustic.json" 2>/dev/null
            local b
            b=$(python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))["noise_threshold"]; print(max(1, round(d["samples"] / d["pixels"])))' \
                out/nt_glass/glass_caustic.json 2>/dev/null || echo 256)
            section "uniform at the same samples: glass_caustic at 512 px, $b spp"
            timed "uniform" "$vk" render --scene glass_caustic --res 512 --spp "$b" --batch 64 --out out/nt_uniform
        fi
        if has main; then
            section "main job: vkmech --scene ring_caustic --spp 64"
            rm -rf out/ring_caustic
            timed "main job" "$vk" --scene ring_caustic --spp 64
            cp out/ring_caustic/ring_caustic.png "$out/" 2>/dev/null
            cp out/ring_caustic/ring_caustic.json "$out/" 2>/dev/null
            section "main job again (warm driver caches)"
            timed "main job 2" "$vk" --scene ring_caustic --spp 64 --out out/ring_caustic2
            section "larger: ring_caustic at 1024 px, 1024 spp"
            timed "ring 1024x1024spp" "$vk" --scene ring_caustic --res 1024 --spp 1024 --batch 64 --out out/ring_big
        fi
        if has pipeline-cache; then
            # vkmech's own pipeline cache alone: the driver's shader disk
            # cache off (__GL_SHADER_DISK_CACHE=0 on NVIDIA, Mesa's too),
            # an empty cache directory, then the same render again.
            local pc
            pc=$(mktemp -d)
            section "pipeline cache: first run (empty cache), then second run"
            for run in first second; do
                __GL_SHADER_DISK_CACHE=0 MESA_SHADER_CACHE_DISABLE=true VKMECH_CACHE_DIR=$pc \
                    "$vk" --scene kitchen_counter --spp 16 --out out/pc-$run | grep -E "pipeline creation|paths/s"
            done
            ls -la "$pc"
        fi
        if has study-quick; then
            section "vkmech study all --preset quick"
            timed "study quick" "$vk" study all --preset quick --out out/study-quick
        fi
        if has paper; then
            section "vkmech study all --preset paper --plan"
            "$vk" study all --preset paper --out out/paper --plan
            section "vkmech study all --preset paper"
            # SIGINT: the study stops cleanly and keeps every finished render,
            # so running this again on the same machine resumes.
            timed "study paper" timeout -s INT "${PAPER_BUDGET_S:-540}" "$vk" study all --preset paper --out out/paper
            tar czf "$out/paper-results.tar.gz" --exclude=cache -C out paper 2>/dev/null
        fi
        if has cornell; then
            # The GPU speed check's Cornell box (1024^2, 64 spp, MIS, capture on), each kernel twice.
            local k
            for k in gpu cpu; do
                section "cornell box: vkmech --scene ci/scenes/cornell_box.xml --res 1024 --spp 64 --batch 64 --kernel $k"
                "$vk" --scene ci/scenes/cornell_box.xml --res 1024 --spp 64 --batch 64 --kernel $k --out out/cornell-$k >/dev/null 2>&1
                timed "cornell $k" "$vk" --scene ci/scenes/cornell_box.xml --res 1024 --spp 64 --batch 64 --kernel $k \
                    --out out/cornell-$k >out/cornell-$k.log 2>&1
                grep -E "paths/s|pipeline creation" out/cornell-$k.log
            done
            cp out/cornell-gpu/cornell_box.png "$out/" 2>/dev/null
        fi
        if has envmap; then
            # What an emitter at infinity costs: the validation scene lit by its sky map,
            # then the same scene with the paper's overhead panel instead (each kernel).
            local k e
            for k in gpu cpu; do
                for e in envmap panel; do
                    local opt=()
                    [[ $e == panel ]] && opt=(--environment-panel)
                    section "envmap: val_envmap.xml --res 512 --spp 256 --kernel $k ($e)"
                    "$vk" --scene analysis/validation/scenes/val_envmap.xml --res 64 --spp 4 --kernel $k "${opt[@]}" \
                        --out out/env-warm >/dev/null 2>&1
                    timed "envmap $k $e" "$vk" --scene analysis/validation/scenes/val_envmap.xml --res 512 --spp 256 \
                        --batch 64 --kernel $k "${opt[@]}" --out out/env-$k-$e >out/env-$k-$e.log 2>&1
                    grep -E "paths/s|error" out/env-$k-$e.log
                done
            done
            cp out/env-gpu-envmap/val_envmap.png "$out/" 2>/dev/null
        fi
        if has taxonomy; then
            # What labelling by a taxonomy costs on this device (issue 37): each scene with
            # the built-in buckets, with taxonomies/paper.lpe (the same labels by the DFA,
            # SPEC_TAXONOMY on), with three --lpe queries (a second pass), and kitchen_counter
            # by its example taxonomy; two rounds, alternating; the paths/s line of each
            # (pipeline creation is not in it) and the class table, which paper.lpe must repeat.
            local s v r o
            mkdir -p out
            for r in 1 2; do
                for s in ${TAXONOMY_SCENES:-glass_caustic kitchen_counter ring_caustic}; do
                    local vs=(builtin paper lpe)
                    [[ $s == kitchen_counter ]] && vs+=(material)
                    ((r == 2)) && mapfile -t vs < <(printf '%s\n' "${vs[@]}" | tac)
                    for v in "${vs[@]}"; do
                        case $v in
                            builtin) o=() ;;
                            paper) o=(--taxonomy taxonomies/paper.lpe) ;;
                            lpe) o=(--lpe "caustic=C D S+ [LB]" --lpe "glossy=C .* G .* [LB]" --lpe "anything=C .* [LB]") ;;
                            material) o=(--taxonomy taxonomies/examples/kitchen_caustics_by_material.lpe) ;;
                        esac
                        section "taxonomy round $r: $s at ${TAXONOMY_RES:-512} px, ${TAXONOMY_SPP:-512} spp, $v"
                        timed "taxonomy $s $v" "$vk" render --scene "$s" --res "${TAXONOMY_RES:-512}" --spp "${TAXONOMY_SPP:-512}" \
                            --batch 64 "${o[@]}" --out "out/tax-$s-$v" >"out/tax-$s-$v.log" 2>&1
                        tail -1 "out/tax-$s-$v.log"
                        grep -E "paths/s|pipeline creation|^query |error" "out/tax-$s-$v.log"
                        ((r == 1)) && sed -n -E '/^(class|bucket) /,/^labelled/p; /^lpe\./p' "out/tax-$s-$v.log"
                    done
                done
            done
        fi
        if has profile; then
            # Where the path tracer's time goes on this device, by the shader's clock, with this device's kernel.
            section "vkmech bench render --profile --counters --res 512 --spp 16 --batches 16 (${PROFILE_SCENES:-all scenes})"
            timed "bench render phases" "$vk" bench render --profile --counters --res 512 --spp 16 --batches 16 \
                ${PROFILE_SCENES:+--scenes $PROFILE_SCENES}
        fi
        if has ablation; then
            section "vkmech bench render --ablation --res 512 --spp 64 (what each specialization is worth)"
            timed "bench ablation" "$vk" bench render --ablation --res 512 --spp 64 --scenes ${ABLATION_SCENES:-glass_caustic,kitchen_counter,snooker}
        fi
        if [[ ,$what, == *,bisect,* ]]; then
            section "bisect: bench render --res 512 --spp 64 of each staged binary"
            bisect_run "$out"
        fi
    } 2>&1 | tee "$out/gpu-check.log"
}

# ---- the GPU bisect (docs/gpu.md, "Bisecting a GPU regression") ----
# Staged binaries: .gpu/bisect.tar.xz holds bisect/list (one line per commit:
# short hash, date, subject) and bisect/<hash>/{vkmech,scenes/}. Each binary
# renders the scenes of its own commit, by path.
BISECT_BASE=3631bde
# Besides shaders/, the host code that decides what the GPU runs (kernel_key's files).
KERNEL_HOST_FILES=(host/engine/render/renderer.cpp host/engine/render/gpu_scene.cpp host/engine/accel/bvh.cpp
                   host/engine/render/shader_modules.cpp host/engine/vk/context.cpp
                   host/render/renderer.cpp host/render/gpu_scene.cpp host/accel/bvh.cpp)
bisect_commits() {  # the default list: the base, each later commit that changed shaders/ or those files, HEAD
    { git rev-parse --short=10 "$BISECT_BASE"
      git rev-list --reverse --abbrev-commit --abbrev=10 "$BISECT_BASE"..HEAD -- shaders/ "${KERNEL_HOST_FILES[@]}"
      git rev-parse --short=10 HEAD; } | awk '!seen[$0]++'
}

# What decides a binary's render speed: the path tracer's SPIR-V modules (the
# generated headers, both kernels', right after the build of $1 in $2) and the
# render host code of commit $1. Empty when no header is there (then nothing is
# left out as a duplicate).
kernel_key() {
    local f
    compgen -G "$2/generated/shaders/spv_pathtrace_*.h" >/dev/null || return 0
    { cat "$2"/generated/shaders/spv_pathtrace_*.h
      for f in "${KERNEL_HOST_FILES[@]}"; do git show "$1:$f" 2>/dev/null; done; } | sha256sum | cut -c1-16
}

bisect_stage() {
    git rev-parse --git-dir >/dev/null 2>&1 || { echo "gpu-check: bisect-stage: run it from vkmech's git checkout"; exit 2; }
    local commits=("$@") c key prev_key="" prev=""
    ((${#commits[@]})) || mapfile -t commits < <(bisect_commits)
    local work=${BISECT_WORK:-$root/build-bisect} stage_dir
    stage_dir=$(mktemp -d)
    mkdir -p "$work" "$stage_dir/bisect"
    [[ -d $work/src/.git || -f $work/src/.git ]] || git worktree add --detach -f "$work/src" HEAD >/dev/null
    : >"$stage_dir/bisect/list"
    local n=0 t0 short
    for c in "${commits[@]}"; do
        n=$((n + 1)); t0=$SECONDS
        if [[ $c == worktree ]]; then
            # The working tree's own build (BUILD_DIR, default build/), uncommitted changes included.
            local build=${BUILD_DIR:-build}
            [[ -x $build/vkmech ]] || { echo "gpu-check: bisect-stage: worktree: build first ($build/vkmech)"; exit 2; }
            mkdir -p "$stage_dir/bisect/worktree"
            cp "$build/vkmech" "$stage_dir/bisect/worktree/vkmech" && strip "$stage_dir/bisect/worktree/vkmech"
            cp -r scenes "$stage_dir/bisect/worktree/"
            printf 'worktree %s %s\n' "$(date -u +%F)" "the working tree (on $(git rev-parse --short=10 HEAD), uncommitted changes included)" \
                >>"$stage_dir/bisect/list"
            printf 'gpu-check: bisect-stage: %2d/%d worktree staged\n' "$n" "${#commits[@]}"
            continue
        fi
        if [[ $c == env:* ]]; then
            # The current build under an environment setting (a run-time switch to
            # measure, such as VKMECH_GPU_TALLY=shared): env:NAME:VAR=VALUE.
            local spec=${c#env:} name setting build=${BUILD_DIR:-build}
            name=${spec%%:*}; setting=${spec#*:}
            [[ $name != "$spec" && $setting == [A-Z_]*=* ]] || { echo "gpu-check: bisect-stage: '$c': expected env:NAME:VAR=VALUE"; exit 2; }
            [[ -x $build/vkmech ]] || { echo "gpu-check: bisect-stage: $c: build first ($build/vkmech)"; exit 2; }
            mkdir -p "$stage_dir/bisect/$name"
            cp "$build/vkmech" "$stage_dir/bisect/$name/vkmech.bin" && strip "$stage_dir/bisect/$name/vkmech.bin"
            printf '#!/bin/sh\nexport %q\nexec "$(dirname "$0")/vkmech.bin" "$@"\n' "$setting" >"$stage_dir/bisect/$name/vkmech"
            chmod +x "$stage_dir/bisect/$name/vkmech"
            cp -r scenes "$stage_dir/bisect/$name/"
            printf '%s %s %s\n' "$name" "$(date -u +%F)" "the working tree with $setting (on $(git rev-parse --short=10 HEAD))" \
                >>"$stage_dir/bisect/list"
            printf 'gpu-check: bisect-stage: %2d/%d %s staged\n' "$n" "${#commits[@]}" "$name"
            continue
        fi
        if [[ $c == bin:* ]]; then
            # A variant built by hand from the working tree: $work/bin/NAME/vkmech, with a
            # one-line description in $work/bin/NAME/what (an experiment to measure).
            local name=${c#bin:}
            [[ -x $work/bin/$name/vkmech ]] || { echo "gpu-check: bisect-stage: no $work/bin/$name/vkmech"; exit 2; }
            mkdir -p "$stage_dir/bisect/$name"
            cp "$work/bin/$name/vkmech" "$stage_dir/bisect/$name/vkmech"
            cp -r scenes "$stage_dir/bisect/$name/"
            printf '%s %s %s\n' "$name" "$(date -u +%F)" "$(cat "$work/bin/$name/what" 2>/dev/null || echo "variant $name")" \
                >>"$stage_dir/bisect/list"
            printf 'gpu-check: bisect-stage: %2d/%d %s staged\n' "$n" "${#commits[@]}" "$name"
            continue
        fi
        short=$(git rev-parse --short=10 "$c^{commit}") || { echo "gpu-check: bisect-stage: no commit '$c'"; exit 2; }
        mkdir -p "$stage_dir/bisect/$short"
        if [[ -x $work/bin/$short/vkmech ]]; then
            # Built by an earlier bisect-stage: a commit's binary does not change.
            cp "$work/bin/$short/vkmech" "$stage_dir/bisect/$short/vkmech"
        else
            # One worktree and one build directory for every commit: checking a
            # commit out touches only the files it changes, so each build is incremental.
            if ! git -C "$work/src" checkout -q -f --detach "$short"; then
                echo "gpu-check: bisect-stage: cannot check $short out in $work/src; left out"
                rm -rf "${stage_dir:?}/bisect/$short"
                continue
            fi
            if ! { cmake -S "$work/src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release >"$work/cmake.log" 2>&1 &&
                   cmake --build "$work/build" --target vkmech -j"$(nproc)" >"$work/build.log" 2>&1; }; then
                echo "gpu-check: bisect-stage: $short does not build (log: $work/build.log); left out"
                rm -rf "${stage_dir:?}/bisect/$short"
                continue
            fi
            mkdir -p "$work/bin/$short"
            cp "$work/build/vkmech" "$work/bin/$short/vkmech" && strip "$work/bin/$short/vkmech"
            kernel_key "$short" "$work/build" >"$work/bin/$short/key"
            cp "$work/bin/$short/vkmech" "$stage_dir/bisect/$short/vkmech"
        fi
        # A commit that changed neither the path tracer's SPIR-V nor the render host
        # code renders as fast as the one before it: not worth GPU time.
        key=$(cat "$work/bin/$short/key" 2>/dev/null)
        if [[ -n $key && $key == "$prev_key" ]]; then
            echo "gpu-check: bisect-stage: $short left out: the same path tracer and render code as $prev"
            rm -rf "${stage_dir:?}/bisect/$short"
            continue
        fi
        prev_key=$key prev=$short
        git archive "$short" scenes | tar -x -C "$stage_dir/bisect/$short"
        printf '%s %s %s\n' "$short" "$(git log -1 --format=%cs "$short")" "$(git log -1 --format=%s "$short" | cut -c1-70)" \
            >>"$stage_dir/bisect/list"
        printf 'gpu-check: bisect-stage: %2d/%d %s built in %d s\n' "$n" "${#commits[@]}" "$short" $((SECONDS - t0))
    done
    mkdir -p .gpu
    # One solid archive: the binaries differ little, so it compresses to a few of them.
    tar -C "$stage_dir" -cf - bisect | xz -T0 -9 --lzma2=dict=192MiB >.gpu/bisect.tar.xz
    rm -rf "$stage_dir"
    du -h .gpu/bisect.tar.xz
    echo "gpu-check: bisect staged ($(tar -xJOf .gpu/bisect.tar.xz bisect/list | wc -l) binaries); stage the current build too ('stage'), then there: bash ci/gpu-check.sh run bisect"
}

# The default: the three scenes the kernel rounds moved most apart on the H200
# (glass_caustic: the register stack; kitchen_counter: the texel-buffer tree;
# cubes_dof: 40 triangles, shading alone).
bisect_scenes() { echo "${BISECT_SCENES:-glass_caustic,kitchen_counter,cubes_dof}"; }

# bisect_fit N: sets B_SCENES, B_ROUNDS and B_EST (seconds) for N binaries. What
# BISECT_SCENES / BISECT_ROUNDS do not fix is fitted under the budget: two
# rounds, then one, then fewer of the default scenes (at least one).
bisect_est() { awk -v n="$1" -v s="$2" -v r="$3" 'BEGIN { printf "%d", n * r * (0.6 + 1.4 * s) + n * s * 0.36 }'; }
bisect_fit() {
    local n=$1 budget=${BISECT_BUDGET_S:-230} ns
    B_SCENES=$(bisect_scenes); B_ROUNDS=${BISECT_ROUNDS:-2}
    ns=$(tr ',' '\n' <<<"$B_SCENES" | grep -c .)
    B_EST=$(bisect_est "$n" "$ns" "$B_ROUNDS")
    if ((B_EST > budget)) && [[ -z ${BISECT_ROUNDS:-} ]]; then B_ROUNDS=1; B_EST=$(bisect_est "$n" "$ns" 1); fi
    while ((B_EST > budget && ns > 1)) && [[ -z ${BISECT_SCENES:-} ]]; do
        B_SCENES=${B_SCENES%,*}; ns=$((ns - 1)); B_EST=$(bisect_est "$n" "$ns" "$B_ROUNDS")
    done
}

# What `run bisect` would do and its estimated time, from the staged list (or,
# before staging, the default commits). The estimate's figures were measured
# on the H200 on 2026-11-26 (docs/gpu.md): a process start with its Vulkan
# device 0.6 s, a scene 1.4 s (load, three pipelines from the warm shader
# cache, 12 renders of 512^2 x 64 paths), and the parallel warm-up 0.36 s per
# binary and scene.
bisect_plan() {
    local list
    if [[ -f .gpu/bisect.tar.xz ]]; then list=$(tar -xJOf .gpu/bisect.tar.xz bisect/list)
    else list=$(bisect_commits | while read -r c; do printf '%s %s %s\n' "$c" "$(git log -1 --format=%cs "$c")" "$(git log -1 --format=%s "$c" | cut -c1-70)"; done)
         echo "(not staged yet: the default commits of bisect-stage)"; fi
    local n nscenes budget=${BISECT_BUDGET_S:-230}
    n=$(printf '%s\n' "$list" | grep -c .)
    bisect_fit "$n"
    local scenes=$B_SCENES rounds=$B_ROUNDS est=$B_EST
    nscenes=$(tr ',' '\n' <<<"$scenes" | grep -c .)
    echo "bisect plan: $n binaries x $nscenes scenes ($scenes) x $rounds rounds, alternating;"
    echo "  each: vkmech bench render --res 512 --spp 64 --scenes <its commit's scene files>"
    echo "  first, every binary renders each scene once at 32^2 (in parallel) to fill the driver's shader cache"
    echo "  estimated ${est} s on an H200; the run stops at ${budget} s (BISECT_BUDGET_S) and reports the rounds it finished"
    ((est > 240)) && echo "  over 4 minutes: set BISECT_SCENES to fewer scenes, BISECT_ROUNDS=1, or stage fewer commits"
    printf '%s\n' "$list" | awk '{ printf "  %2d  %s\n", NR, $0 }'
}

bisect_run() {
    local out=$1
    [[ -f .gpu/bisect.tar.xz ]] || { echo "gpu-check: no .gpu/bisect.tar.xz: run 'bash ci/gpu-check.sh bisect-stage' here"; return 2; }
    bisect_plan
    local dir=$root/out/bisect
    rm -rf "$dir" && mkdir -p "$dir" && tar -xJf .gpu/bisect.tar.xz -C "$dir"
    local scenes rounds budget=${BISECT_BUDGET_S:-230} t0=$SECONDS
    mapfile -t hashes < <(awk '{print $1}' "$dir/bisect/list")
    bisect_fit "${#hashes[@]}"
    scenes=$B_SCENES; rounds=$B_ROUNDS
    # The driver's shader cache in one place for every binary, large enough for all.
    export __GL_SHADER_DISK_CACHE=1 __GL_SHADER_DISK_CACHE_PATH=$dir/glcache __GL_SHADER_DISK_CACHE_SIZE=4000000000 \
        __GL_SHADER_DISK_CACHE_SKIP_CLEANUP=1
    mkdir -p "$dir/glcache"
    paths_of() { tr ',' '\n' <<<"$scenes" | sed "s#^#$dir/bisect/$1/scenes/#; s#\$#.xml#" | paste -sd, -; }
    local h
    for h in "${hashes[@]}"; do echo "$h $(paths_of "$h")"; done |
        xargs -P "$(nproc)" -L1 sh -c '"$0"/bisect/"$1"/vkmech bench render --res 32 --spp 1 --scenes "$2" >/dev/null 2>&1 || echo "warm-up failed: $1"' "$dir"
    printf 'bisect: warm-up %d s\n' $((SECONDS - t0))
    : >"$dir/results"
    local r i order
    for ((r = 1; r <= rounds; ++r)); do
        order=("${hashes[@]}")
        if ((r % 2 == 0)); then mapfile -t order < <(printf '%s\n' "${hashes[@]}" | tac); fi
        for h in "${order[@]}"; do
            if ((SECONDS - t0 > budget)); then echo "bisect: budget of ${budget} s reached in round $r"; break 2; fi
            "$dir/bisect/$h/vkmech" bench render --res "${BISECT_RES:-512}" --spp "${BISECT_SPP:-64}" --scenes "$(paths_of "$h")" \
                >"$dir/$h.$r.log" 2>&1 ||
                echo "bisect: $h round $r failed: $(tail -1 "$dir/$h.$r.log")"
            # The specialized column of the software-BVH rows.
            awk -v h="$h" -v r="$r" '$2 == "bvh" && $3 ~ /^[0-9.]+$/ { print h, r, $1, $3 }' "$dir/$h.$r.log" >>"$dir/results"
        done
        printf 'bisect: round %d done at %d s\n' "$r" $((SECONDS - t0))
    done
    cp "$dir/results" "$out/bisect-results.txt"
    echo "bisect: each binary's first-round output (all columns: specialized, generic, capture off):"
    for h in "${hashes[@]}"; do echo "--- $h"; grep -E '^[a-z_]+ +bvh ' "$dir/$h.1.log"; done
    /usr/bin/env python3 - "$dir/bisect/list" "$dir/results" "$scenes" <<'PY' | tee "$out/bisect-table.md"
import collections, os, sys
lst = [l.split(" ", 2) for l in open(sys.argv[1]).read().splitlines() if l.strip()]
res = collections.defaultdict(list)
for l in open(sys.argv[2]):
    h, r, scene, v = l.split()
    res[(h, scene)].append(float(v))
scenes = sys.argv[3].split(",")
base = {s: (sum(res[(lst[0][0], s)]) / len(res[(lst[0][0], s)]) if res[(lst[0][0], s)] else None) for s in scenes}
print(f"bench render --res {os.environ.get('BISECT_RES', '512')} --spp {os.environ.get('BISECT_SPP', '64')}, specialized pipeline, software BVH: millions of paths/s, mean of the rounds "
      "(each a median of 3); in brackets, the ratio to the first row")
print("| commit | date | " + " | ".join(scenes) + " | subject |")
print("|---|---|" + "---:|" * len(scenes) + "---|")
for h, date, subj in lst:
    cells = []
    for s in scenes:
        v = res[(h, s)]
        if not v: cells.append("-"); continue
        m = sum(v) / len(v)
        spread = f" ±{(max(v) - min(v)) / 2 / m * 100:.0f}%" if len(v) > 1 else ""
        ratio = f" ({m / base[s]:.2f})" if base[s] else ""
        cells.append(f"{m:.3g}{spread}{ratio}")
    print(f"| {h} | {date} | " + " | ".join(cells) + f" | {subj.replace('|', '/')} |")
PY
}

case ${1:-} in
    stage) stage ;;
    run) run "${2:-all}" "${3:-}" ;;
    bisect-stage) shift; bisect_stage "$@" ;;
    *) echo "usage: bash ci/gpu-check.sh stage | bisect-stage [COMMIT...] | run [devices,tests,gpu-tests,bench,main,pipeline-cache,study-quick,paper,cornell,envmap,threshold,taxonomy,profile,ablation,bisect|all] [--plan]"; exit 2 ;;
esac
