#!/usr/bin/env node
// Read a VRM Animation (.vrma) with pixiv's own loader (@pixiv/three-vrm-animation on three.js),
// as three-vrm applications do, and print what it found as JSON: the duration, the humanoid
// bones with rotation tracks, the bones with translation tracks, the preset and custom
// expressions, the hips' rest position. Usage: node vrma-read.mjs FILE.vrma
// scripts/setup-debian.sh installs the packages into /opt/vrma-reader ($VRMA_READER_DIR).
import * as fs from 'fs';
import * as path from 'path';
import { pathToFileURL } from 'url';

const dir = path.join(process.env.VRMA_READER_DIR || '/opt/vrma-reader', 'node_modules');
const load = (p) => import(pathToFileURL(path.join(dir, p)).href);
const { GLTFLoader } = await load('three/examples/jsm/loaders/GLTFLoader.js');
const { VRMAnimationLoaderPlugin } = await load('@pixiv/three-vrm-animation/lib/three-vrm-animation.module.js');
const file = process.argv[2];
if (!file) {
  console.error('usage: vrma-read.mjs FILE.vrma');
  process.exit(2);
}
const bytes = fs.readFileSync(file);
const loader = new GLTFLoader();
loader.register((parser) => new VRMAnimationLoaderPlugin(parser));
loader.parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength), '', (gltf) => {
  const a = (gltf.userData.vrmAnimations || [])[0];
  if (!a) {
    console.error(`${file}: no VRM animation in it`);
    process.exit(1);
  }
  const hips = a.restHipsPosition;
  console.log(JSON.stringify({
    duration: a.duration,
    rotation: [...a.humanoidTracks.rotation.keys()],
    translation: [...a.humanoidTracks.translation.keys()],
    preset: [...a.expressionTracks.preset.keys()],
    custom: [...a.expressionTracks.custom.keys()],
    rest_hips: [hips.x, hips.y, hips.z],
  }));
}, (e) => {
  console.error(`${file}: ${e.message || e}`);
  process.exit(1);
});
