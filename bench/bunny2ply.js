// bunny2ply.js MODULE_DIR OUT.ply -- the npm package `bunny` (the Stanford
// bunny as {positions: [[x, y, z]...], cells: [[a, b, c]...]}) written as a
// binary little-endian PLY in the same layout genmesh writes.
'use strict';
const fs = require('fs');
const path = require('path');
if (process.argv.length !== 4) {
  console.error('usage: node bunny2ply.js MODULE_DIR OUT.ply');
  process.exit(2);
}
const bunny = require(path.resolve(process.argv[2]));
const pos = bunny.positions, cells = bunny.cells;
const header = 'ply\nformat binary_little_endian 1.0\ncomment Stanford bunny from npm bunny\n' +
  `element vertex ${pos.length}\nproperty float x\nproperty float y\nproperty float z\n` +
  `element face ${cells.length}\nproperty list uchar uint vertex_indices\nend_header\n`;
const body = Buffer.alloc(pos.length * 12 + cells.length * 13);
let o = 0;
for (const p of pos) for (let k = 0; k < 3; k++) { body.writeFloatLE(p[k], o); o += 4; }
for (const c of cells) {
  if (c.length !== 3) throw new Error('bunny: a cell that is not a triangle');
  body.writeUInt8(3, o); o += 1;
  for (let k = 0; k < 3; k++) { body.writeUInt32LE(c[k], o); o += 4; }
}
fs.writeFileSync(process.argv[3], Buffer.concat([Buffer.from(header, 'ascii'), body]));
