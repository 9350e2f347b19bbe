#!/usr/bin/env bash
# The standing GPU check: vkmech on a real GPU machine that has a Vulkan
# driver but none of our Debian packages (the lent NVIDIA machines).
#
#   bash ci/gpu-check.sh stage        # here, after building: copies the binaries,
#                                     # their shared libraries, the Vulkan loader and
#                                     # the validation layer into .gpu/ (git-ignored)
#   bash ci/gpu-check.sh run [WHAT]   # there, from the repository root: runs
#                                     # WHAT (default: all) and writes logs to $OUT
#
# WHAT is a comma-separated list of: devices, tests, bench, main, pipeline-cache, study-quick,
# paper (the paper preset of every study, as far as PAPER_BUDGET_S allows).
# Results go to docs/gpu.md by hand, with the device, driver and date.
set -uo pipefail
cd "$(dirname "$0")/.."
root=$PWD

stage() {
    local build=${BUILD_DIR:-build}
    [[ -x $build/vkmech && -x $build/vkmech_tests ]] || { echo "gpu-check: build first ($build/vkmech)"; exit 2; }
    rm -rf .gpu && mkdir -p .gpu/bin .gpu/lib .gpu/lib-fallback .gpu/layers
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

run() {
    local what=${1:-all}
    local out=${OUT:-$root/out/gpu-check}
    mkdir -p "$out"
    [[ -d .gpu/bin ]] || { echo "gpu-check: no .gpu/ here: run 'bash ci/gpu-check.sh stage' and carry .gpu and .gl"; exit 2; }
    local f
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
        if has tests; then
            section "GPU test suites (vkmech_tests -ts=gpu)"
            timed "gpu tests" stdbuf -oL "$root/build/vkmech_tests" -ts=gpu
            section "CPU test suites"
            timed "cpu tests" "$root/build/vkmech_tests" -tse=gpu
        fi
        if has bench; then
            section "vkmech bench traversal (defaults: 2^18 rays)"
            timed "bench traversal" "$vk" bench traversal
            section "vkmech bench traversal --rays 4194304"
            timed "bench traversal 4M" "$vk" bench traversal --rays 4194304
            # The ray kernel's slices, off on GPUs by default until measured on one:
            # the bvh column with them, against the one-ray-per-invocation column.
            section "vkmech bench traversal --bvh-only --slices --rays 4194304"
            timed "bench traversal slices" "$vk" bench traversal --bvh-only --slices --rays 4194304
            section "vkmech bench render (defaults: 128^2, 8 spp)"
            timed "bench render" "$vk" bench render
            section "vkmech bench render --res 512 --spp 64"
            timed "bench render 512" "$vk" bench render --res 512 --spp 64
            # Where the path tracer's time goes on this device, by the shader's clock.
            section "vkmech bench render --profile --counters --res 512 --spp 16 --batches 16"
            timed "bench render phases" "$vk" bench render --profile --counters --res 512 --spp 16 --batches 16
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
    } 2>&1 | tee "$out/gpu-check.log"
}

case ${1:-} in
    stage) stage ;;
    run) run "${2:-all}" ;;
    *) echo "usage: bash ci/gpu-check.sh stage | run [devices,tests,bench,main,study-quick,paper|all]"; exit 2 ;;
esac
