#!/usr/bin/env node
// Validates a .gltf (with its external .bin and images) or .glb with the
// Khronos glTF validator (npm package gltf-validator):
//   npm install --prefix /work/scratch/gv gltf-validator
//   NODE_PATH=/work/scratch/gv/node_modules node scripts/validate_gltf.js out/demo/gltf/model.gltf
// Prints the validator's issue summary and messages; exits 1 when there are errors.
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const file = process.argv[2];
if (!file) {
  console.error('usage: validate_gltf.js MODEL.gltf|MODEL.glb');
  process.exit(2);
}
const bytes = new Uint8Array(fs.readFileSync(file));
validator.validateBytes(bytes, {
  uri: path.basename(file),
  maxIssues: 100,
  externalResourceFunction: (uri) =>
    new Promise((resolve, reject) => {
      fs.readFile(path.join(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
        err ? reject(err.toString()) : resolve(new Uint8Array(data)));
    }),
}).then((report) => {
  console.log(JSON.stringify({validatorVersion: report.validatorVersion, issues: {
    numErrors: report.issues.numErrors, numWarnings: report.issues.numWarnings,
    numInfos: report.issues.numInfos, numHints: report.issues.numHints,
    messages: report.issues.messages}, info: report.info}, null, 2));
  process.exit(report.issues.numErrors > 0 ? 1 : 0);
}, (error) => {
  console.error('validation failed:', error);
  process.exit(1);
});
