// Validates glTF files with the Khronos glTF validator (npm package gltf-validator, installed by
// tools/setup.sh into tools/npm/). Usage: node tools/validate_gltf.cjs FILE...
// Prints one line per file: "FILE: N errors, N warnings, N infos, N hints" and the first errors;
// exits 1 when any file has an error (or cannot be read), 0 otherwise.
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require(path.join(__dirname, 'npm', 'node_modules', 'gltf-validator'));

async function validate(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {maxIssues: 100});
  const issues = report.issues;
  console.log(`${file}: ${issues.numErrors} errors, ${issues.numWarnings} warnings, ${issues.numInfos} infos, ${issues.numHints} hints`);
  for (const m of issues.messages.filter((m) => m.severity === 0).slice(0, 10)) console.log(`  error ${m.code} at ${m.pointer}: ${m.message}`);
  for (const m of issues.messages.filter((m) => m.severity === 1).slice(0, 5)) console.log(`  warning ${m.code} at ${m.pointer}: ${m.message}`);
  return issues.numErrors;
}

(async () => {
  let errors = 0;
  for (const file of process.argv.slice(2)) {
    try {
      errors += await validate(file);
    } catch (e) {
      console.log(`${file}: cannot validate: ${e.message || e}`);
      errors += 1;
    }
  }
  process.exit(errors > 0 ? 1 : 0);
})();
