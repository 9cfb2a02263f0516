#!/usr/bin/env bash
# Regenerates the preview PNGs in docs/ with `signcast render` (the middle frame of each clip).
set -euo pipefail
cd "$(dirname "$0")"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for letter in A B; do
  lower=$(echo "$letter" | tr A-Z a-z)
  for look in shaded flat; do
    signcast render ase "$letter" -o "$tmp/$letter.mkv" --look "$look" --preview "letter-$lower-$look.png"
  done
done
# The segmented (FBA-style) body: each vertex follows one bone, so the skin splits at shoulder, elbow and wrist.
signcast render ase B -o "$tmp/seams.mkv" --segmented --size 704x576 --preview segmented-seams.png
signcast render ase B -o "$tmp/seamless.mkv" --size 704x576 --preview seamless-skin.png
