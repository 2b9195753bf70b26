// Validate glTF/GLB files with the Khronos glTF validator; prints one JSON summary per file.
// Usage: node tools/validate_gltf.mjs FILE...   (NODE_PATH must reach the gltf-validator package)
import { createRequire } from "module";
import { readFileSync } from "fs";
import path from "path";

const require = createRequire(import.meta.url);
const validator = require("gltf-validator");

for (const file of process.argv.slice(2)) {
  const data = new Uint8Array(readFileSync(file));
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    externalResourceFunction: () => Promise.reject(new Error("external resources are not used")),
  });
  const issues = report.issues;
  console.log(JSON.stringify({
    file,
    numErrors: issues.numErrors,
    numWarnings: issues.numWarnings,
    messages: issues.messages.filter((m) => m.severity === 0).slice(0, 20),
  }));
}
