#!/usr/bin/env bash
# End-to-end test of `drumsim live` against a real JACK server (tests/live_jack.rs).
# The test starts and stops its own jackd (dummy driver, 48 kHz, 256 frames, a private
# server name), so nothing has to be running. It needs, on Debian/Ubuntu:
#   DEBIAN_FRONTEND=noninteractive apt-get install -y jackd2 libjack-jackd2-dev libasound2-dev
# Prints the measured MIDI-to-sound latency (mean, median, max).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v jackd >/dev/null; then
    echo "test-live-jack: jackd is not installed (apt-get install -y jackd2 libjack-jackd2-dev)" >&2
    exit 1
fi
exec cargo test --features jack --test live_jack -- --nocapture "$@"
