// Validate a .glb or .gltf file with the Khronos glTF validator and print its report as JSON.
// Exit status: 0 when the report has no errors, 1 when it has, 2 when the file cannot be read.
//   node tests/tools/gltf/validate.js FILE
const fs = require("fs");
const validator = require("gltf-validator");

const file = process.argv[2];
let bytes;
try {
  bytes = new Uint8Array(fs.readFileSync(file));
} catch (e) {
  console.error(`validate.js: cannot read ${file}: ${e.message}`);
  process.exit(2);
}
validator
  .validateBytes(bytes, { uri: file, maxIssues: 100 })
  .then((report) => {
    console.log(JSON.stringify(report, null, 2));
    process.exit(report.issues.numErrors > 0 ? 1 : 0);
  })
  .catch((e) => {
    console.error(`validate.js: ${e}`);
    process.exit(2);
  });
