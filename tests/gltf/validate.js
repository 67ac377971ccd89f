// Usage: node validate.js FILE.glb -> prints the validator's summary; exits 1 on any error.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const file = process.argv[2];
const data = new Uint8Array(fs.readFileSync(file));
validator.validateBytes(data, {uri: path.basename(file), maxIssues: 100})
  .then((report) => {
    const i = report.issues;
    console.log(`${file}: errors ${i.numErrors}, warnings ${i.numWarnings}, infos ${i.numInfos}, ` +
                `hints ${i.numHints}; validator ${report.validatorVersion}`);
    for (const m of i.messages) {
      if (m.severity <= 1) console.log(`  [${m.severity}] ${m.code} ${m.pointer || ''}: ${m.message}`);
    }
    process.exit(i.numErrors === 0 ? 0 : 1);
  })
  .catch((e) => { console.error(`${file}: validator failed: ${e}`); process.exit(1); });
