#!/bin/bash
# Issue #23: what a lent GPU machine needs, prepared HERE (it reaches no network), in folders that
# git ignores and the device tool carries: .gl (EGL/GL loaders), .whl (mcpt's wheels for the
# machine's Python 3.12, and Mitsuba 3 + drjit pruned to cuda_ad_rgb: the wheel alone is 62 MB,
# over the 64 MiB transfer), .xshared (a copy of ../shared: scenes and the Mitsuba tool).
# Then, with the device tool: run `bash bench/device/run.sh` carrying .gl .whl .xshared
# (about 55 MB; see bench/RESULTS.md, the H200 section, for what it printed on 2026-11-28).
set -euo pipefail
cd "$(dirname "$0")/../.."
PIP=${PIP:-.venv/bin/python -m pip}
PLAT="--platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64
      --platform manylinux2014_x86_64 --platform manylinux1_x86_64"
mkdir -p .gl .whl /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
apt-get $o update -qq && (cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
# mcpt's own needs that the machine's image lacks (numpy, click, PyYAML, opencv are there)
for p in moderngl==5.13.0 glcontext==3.1.0 assimp_py==1.1.0 OpenEXR==3.5.3 pydantic==2.14.4 \
         pydantic_core==2.50.5 annotated-types==0.8.0 typing-inspection==0.4.5 typing_extensions==4.16.0 \
         setuptools==84.2.1 wheel==0.48.0; do
  $PIP download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp $PLAT -d .whl "$p"
done
# Mitsuba 3.9.1 + drjit 1.5.0 as one site folder: only the cuda_ad_rgb and scalar_rgb variants
if [ ! -f .whl/mitsuba-drjit-site.tar.xz ]; then
  tmp=$(mktemp -d) root=$PWD
  $PIP download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp $PLAT -d "$tmp" \
      mitsuba==3.9.1 drjit==1.5.0
  mkdir "$tmp/site" && (cd "$tmp/site" && for w in "$tmp"/*.whl; do unzip -q -o "$w"; done
    cd mitsuba && rm -rf llvm_ad_* cuda_ad_mono* cuda_ad_spectral* scalar_spectral* include cmake pkgconfig \
       mitsuba_stubs ./*.pyi plugins/ellipsoids*.so plugins/volpathmis.so plugins/bsplinecurve.so \
       plugins/sdfgrid.so plugins/*sunsky*.so plugins/ptracer.so
    cd .. && rm -rf drjit/include drjit/cmake && tar -cJf "$root/.whl/mitsuba-drjit-site.tar.xz" .)
  rm -rf "$tmp"
fi
rm -rf .xshared && cp -r ../shared .xshared
du -sh .gl .whl .xshared
