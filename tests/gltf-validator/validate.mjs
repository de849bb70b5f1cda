// Validates glTF/GLB files with the Khronos glTF validator (npm package gltf-validator) and
// prints one JSON line per file: {file, errors, warnings, messages: [code: message at pointer]}.
// Exit status: 0 when no file has an error, 1 otherwise, 2 on a usage or read failure.
import fs from 'node:fs';
import path from 'node:path';
import validator from 'gltf-validator';

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate.mjs FILE.gltf|FILE.glb ...');
  process.exit(2);
}
let failed = false;
for (const file of files) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 50,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.join(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(data)));
      }),
  });
  const issues = report.issues;
  console.log(JSON.stringify({
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    messages: issues.messages.map((m) => `${m.code}: ${m.message} at ${m.pointer ?? ''}`),
  }));
  if (issues.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
