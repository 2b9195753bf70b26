#!/usr/bin/env bash
# Vendors three.js (npm package `three`, pinned) into the viewer's package data, checking the tarball
# against the registry's integrity hash. Run it to update: change VERSION and INTEGRITY together.
# Only the files the page loads are kept (the ES module build, its core, OrbitControls) with the licence.
set -euo pipefail
VERSION=0.176.0
INTEGRITY='sha512-PWRKYWQo23ojf9oZSlRGH8K09q7nRSWx6LY/HF/UUrMdYgN9i1e2OwJYHoQjwc6HF/4lvvYLC5YC1X8UJL2ZpA=='
cd "$(dirname "$0")/.."
dest=src/mocapkit/view/static/vendor/three
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$work" && npm pack "three@$VERSION" --silent >/dev/null)
tgz="$work/three-$VERSION.tgz"
got="sha512-$(openssl dgst -sha512 -binary "$tgz" | base64 -w0)"
if [ "$got" != "$INTEGRITY" ]; then echo "three@$VERSION: integrity mismatch ($got)" >&2; exit 1; fi
tar xzf "$tgz" -C "$work"
mkdir -p "$dest"
cp "$work/package/build/three.module.min.js" "$work/package/build/three.core.min.js" \
   "$work/package/examples/jsm/controls/OrbitControls.js" "$work/package/LICENSE" "$dest/"
printf 'three@%s from the npm registry (%s)\n' "$VERSION" "$INTEGRITY" > "$dest/VERSION"
echo "vendored three@$VERSION into $dest"
