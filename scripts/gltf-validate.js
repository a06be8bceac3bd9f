#!/usr/bin/env node
// Validate one glTF / GLB file with the Khronos glTF-Validator (npm package gltf-validator).
// Usage: node gltf-validate.js FILE.glb
// Prints "errors=N warnings=N infos=N hints=N", then each message; exit 0 when N errors is 0,
// 1 when there are errors, 2 on bad usage. The package is found through NODE_PATH or next to
// this script (scripts/setup-debian.sh installs it into /opt/gltf-validator and links it here).
const fs = require("fs");
const path = require("path");
let validator;
try {
  validator = require("gltf-validator");
} catch (e) {
  validator = require(path.join(process.env.GLTF_VALIDATOR_DIR || "/opt/gltf-validator", "node_modules", "gltf-validator"));
}
const file = process.argv[2];
if (!file) {
  console.error("usage: gltf-validate.js FILE.glb");
  process.exit(2);
}
const bytes = new Uint8Array(fs.readFileSync(file));
validator
  .validateBytes(bytes, { uri: path.basename(file), maxIssues: 100 })
  .then((report) => {
    const i = report.issues;
    console.log(`errors=${i.numErrors} warnings=${i.numWarnings} infos=${i.numInfos} hints=${i.numHints}`);
    for (const m of i.messages) {
      console.log(`${["error", "warning", "info", "hint"][m.severity]} ${m.code} ${m.pointer || ""}: ${m.message}`);
    }
    process.exit(i.numErrors === 0 ? 0 : 1);
  })
  .catch((e) => {
    console.error(`gltf-validate: ${e}`);
    process.exit(2);
  });
