#!/usr/bin/env bash
# The release check: build kartci's sdist and wheel as a release would (python -m build: the
# wheel is built from the sdist, so a file the sdist lacks fails here), check their metadata as
# PyPI would (twine check --strict), install the wheel into an empty venv with the pinned
# dependencies and run one scenario with it in an empty folder (not a project: the built-in
# worlds, models and scenarios must come from the wheel). Run by .ci/run and by
# .github/workflows/release.yml before it publishes.
#
#   tools/check_release.sh [DIST]     DIST: where the sdist and wheel are kept (default: a
#                                     temporary folder, removed at the end)
# PYTHON names the interpreter that has `build` and `twine` (default python3); BUILD_ARGS are
# passed to `python -m build` (--no-isolation builds with the installed hatchling, offline).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
python="${PYTHON:-python3}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
dist="${1:-$work/dist}"
mkdir -p "$dist"
rm -f "$dist"/kartci-*

# shellcheck disable=SC2086  # BUILD_ARGS is a list of options
"$python" -m build -q ${BUILD_ARGS:-} --outdir "$dist" "$root" > "$work/build.log" 2>&1 \
  || { cat "$work/build.log"; exit 1; }
built=$SECONDS
"$python" -m twine check --strict "$dist"/kartci-*
"$python" - "$dist" <<'PY'
"""The sdist holds what the wheel is built from; the wheel holds the package and its data."""
import sys, tarfile, zipfile
from pathlib import Path

dist = Path(sys.argv[1])
(sdist,) = dist.glob("kartci-*.tar.gz")
(wheel,) = dist.glob("kartci-*.whl")
top = {n.split("/", 2)[1] for n in tarfile.open(sdist).getnames() if n.count("/") >= 1}
assert {"kartci", "scenarios", "models", "sims", "pyproject.toml", "README.md"} <= top, top
names = zipfile.ZipFile(wheel).namelist()
for want in ("kartci/__main__.py", "kartci/py.typed",
             "kartci/data/builtin/scenarios/line_straight.yaml"):
    assert want in names, f"{wheel.name} lacks {want}"
assert not any(n.startswith(("tests/", "baselines/")) for n in names), "tests in the wheel"
print(f"{sdist.name}: {sdist.stat().st_size / 1e6:.1f} MB, {wheel.name}: "
      f"{wheel.stat().st_size / 1e6:.1f} MB, {len(names)} files")
PY

"$python" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --disable-pip-version-check \
  -c "$root/constraints.txt" "$dist"/kartci-*.whl
installed=$SECONDS
mkdir "$work/empty"
cd "$work/empty"
env -u KARTCI_ROOT -u PYTHONPATH "$work/venv/bin/kartci" run line_straight --no-strict \
  --set duration_s=2 --set 'criteria={}' --set metrics.line_tracking.transient_s=1 \
  --out "$work/run"
test -s "$work/run/line_straight/run.mcap"
echo "release check passed: $(cd "$dist" && echo kartci-*) in ${SECONDS} s (build ${built} s," \
  "install $((installed - built)) s, run $((SECONDS - installed)) s)"
