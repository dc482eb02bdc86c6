// node validate.js FILE.gltf|FILE.glb...
// Runs the Khronos glTF-Validator (npm gltf-validator, pinned in package.json) on every file and
// prints one line per file: `ok FILE: ...` with zero errors, `FAIL FILE: ...` otherwise, then
// every issue. Exits 1 when any file has an error (warnings, infos and hints are printed, not
// failed). Used by ../check_gltf.sh, which installs the validator; NODE_PATH points at it.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

async function check(file) {
  const data = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(data, {
    uri: file,
    maxIssues: 100,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (e, d) =>
          e ? reject(e.toString()) : resolve(new Uint8Array(d)));
      }),
  });
  const i = report.issues;
  const info = report.info;
  const verdict = i.numErrors === 0 ? 'ok' : 'FAIL';
  console.log(`${verdict} ${file}: validator ${validator.version()}: errors=${i.numErrors} warnings=${i.numWarnings} infos=${i.numInfos} hints=${i.numHints}; ` +
    `animations=${info.animationCount} skins=${info.hasSkins} triangles=${info.totalTriangleCount} materials=${info.materialCount}`);
  for (const m of i.messages) {
    console.log(`  [severity ${m.severity}] ${m.code} ${m.pointer || ''}: ${m.message}`);
  }
  return i.numErrors === 0;
}

(async () => {
  const files = process.argv.slice(2);
  if (files.length === 0) {
    console.error('usage: node validate.js FILE.gltf|FILE.glb...');
    process.exit(2);
  }
  let failed = 0;
  for (const f of files) {
    try {
      if (!(await check(f))) failed++;
    } catch (e) {
      console.log(`FAIL ${f}: validator could not read it: ${e}`);
      failed++;
    }
  }
  console.log(`gltf-validator: ${files.length - failed} passed, ${failed} failed`);
  process.exit(failed ? 1 : 0);
})();
