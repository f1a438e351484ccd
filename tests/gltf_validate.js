// Validate a glTF/GLB file with the official Khronos validator (npm package gltf-validator)
// and print its JSON report. Usage: node gltf_validate.js FILE [NODE_MODULES_DIR]
const fs = require("fs");
const path = require("path");
const file = process.argv[2];
const modules = process.argv[3] || "node_modules";
const validator = require(path.resolve(modules, "gltf-validator"));
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: path.basename(file),
  maxIssues: 1000,
  externalResourceFunction: (uri) => new Promise((resolve, reject) => {
    fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) => err ? reject(err.toString()) : resolve(data));
  }),
}).then((report) => {
  console.log(JSON.stringify(report));
}, (error) => {
  console.error(String(error));
  process.exit(1);
});
