// Per-corner MikkTSpace tangents from the npm package `mikktspace` (WASM build of the reference
// implementation). Reads {"position": [...9T], "normal": [...9T], "texcoord": [...6T]} as JSON on
// stdin, prints the [...12T] tangents as JSON. Usage: node mikktspace_oracle.js NODE_MODULES_DIR
const path = require("path");
const { generateTangents } = require(path.resolve(process.argv[2], "mikktspace"));
let input = "";
process.stdin.on("data", (chunk) => { input += chunk; });
process.stdin.on("end", () => {
  const data = JSON.parse(input);
  const tangents = generateTangents(new Float32Array(data.position), new Float32Array(data.normal),
                                    new Float32Array(data.texcoord));
  console.log(JSON.stringify(Array.from(tangents)));
});
