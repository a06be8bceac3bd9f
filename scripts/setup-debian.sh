#!/usr/bin/env bash
# Install what drumsim needs to build and test on Debian/Ubuntu: the ALSA and JACK headers,
# pkg-config, a JACK server (for `drumsim live` and its end-to-end test), and a Rust toolchain
# if there is none. Safe to run again; runs apt only for what is missing.
set -euo pipefail
packages=(pkg-config libasound2-dev libjack-jackd2-dev jackd2 gcc libc6-dev)
# The export tests read the BVH back with assimp and validate the glTF with the Khronos
# glTF-Validator, which runs on Node.js (installed below into /opt/gltf-validator).
packages+=(assimp-utils)
# The General MIDI tests render songs from the wild: OpenTTD's and Planet Blupi's music.
packages+=(openttd-openmsx planetblupi-music-midi)
# GNU time measures a render's peak memory in the tests.
packages+=(time)
# The viewer (`drumsim view`) is tested in a real headless Chromium; `drumsim video` draws
# its frames there and encodes them with ffmpeg. Without a GPU, Chromium draws WebGL fastest
# through Mesa's llvmpipe (EGL and the DRI drivers), about twice SwiftShader's speed.
packages+=(chromium ffmpeg libegl-mesa0 libgl1-mesa-dri)
# The sound server's test reads drumsim's contact messages with liblo's oscdump.
packages+=(liblo-tools)
# The VMC test receives with python-osc (installed below into /opt/drumsim-python).
packages+=(python3 python3-venv)
command -v npm >/dev/null 2>&1 || packages+=(nodejs npm)
sudo=""
[ "$(id -u)" -eq 0 ] || sudo="sudo"
missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
    echo "setup-debian: installing ${missing[*]}" >&2
    $sudo apt-get update -qq
    # jackd2 asks whether to enable realtime scheduling; answer no, non-interactively.
    echo "jackd2 jackd/tweak_rt_limits boolean false" | $sudo debconf-set-selections
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${missing[@]}" >/dev/null
fi
validator=/opt/gltf-validator
if [ ! -d "$validator/node_modules/gltf-validator" ]; then
    echo "setup-debian: installing gltf-validator into $validator" >&2
    $sudo mkdir -p "$validator"
    $sudo npm install --prefix "$validator" --no-audit --no-fund --silent gltf-validator@2.0.0-dev.3.10
fi
reader=/opt/vrma-reader
if [ ! -d "$reader/node_modules/@pixiv/three-vrm-animation" ]; then
    echo "setup-debian: installing three.js and @pixiv/three-vrm-animation into $reader (the VRMA test reads with them)" >&2
    $sudo mkdir -p "$reader"
    $sudo npm install --prefix "$reader" --no-audit --no-fund --silent three@0.187.0 @pixiv/three-vrm-animation@3.5.5
fi
python_env=/opt/drumsim-python
if ! "$python_env/bin/python3" -c "import pythonosc" >/dev/null 2>&1; then
    echo "setup-debian: installing python-osc into $python_env" >&2
    $sudo rm -rf "$python_env"
    $sudo /usr/bin/python3 -m venv "$python_env"
    $sudo "$python_env/bin/pip" install --quiet --disable-pip-version-check python-osc==1.10.2
fi
if ! command -v cargo >/dev/null 2>&1; then
    [ -x "$HOME/.cargo/bin/cargo" ] || {
        echo "setup-debian: installing Rust with rustup" >&2
        command -v curl >/dev/null || { $sudo apt-get install -y -qq curl ca-certificates >/dev/null; }
        curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal -c rustfmt,clippy
    }
    echo "setup-debian: Rust is in ~/.cargo/bin; run: source ~/.cargo/env" >&2
fi
