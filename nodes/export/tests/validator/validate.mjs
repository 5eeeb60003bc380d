// Runs the official Khronos glTF validator on one .glb/.gltf file.
// Prints the validator's issue summary as one JSON object on stdout and exits
// 1 when it reports any error, 2 when the file cannot be read or validated.
// Usage: node validate.mjs FILE
import { readFile } from "node:fs/promises";
import { basename } from "node:path";
import { validateBytes } from "gltf-validator";

const file = process.argv[2];
if (!file) {
  console.error("usage: node validate.mjs FILE");
  process.exit(2);
}

let bytes;
try {
  bytes = new Uint8Array(await readFile(file));
} catch (err) {
  console.error(`${file}: cannot read: ${err.message}`);
  process.exit(2);
}

let report;
try {
  // maxIssues 0 = report every issue, so a test can show all of them.
  report = await validateBytes(bytes, { uri: basename(file), maxIssues: 0 });
} catch (err) {
  console.error(`${file}: validator could not process the file: ${err}`);
  process.exit(2);
}

const issues = report.issues;
console.log(
  JSON.stringify({
    validatorVersion: report.validatorVersion,
    numErrors: issues.numErrors,
    numWarnings: issues.numWarnings,
    numInfos: issues.numInfos,
    numHints: issues.numHints,
    messages: issues.messages,
    info: report.info,
  }),
);
process.exit(issues.numErrors > 0 ? 1 : 0);
