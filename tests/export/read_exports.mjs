// Reads one sample's PLY and OBJ exports with three.js's loaders (PLYLoader, OBJLoader; npm
// three, installed into the build folder by tests/export/npm_install.sh) and checks them
// against what abrad reported and against each other and the glTF export:
//   - the PLY (binary, float positions, Y up): VERTICES vertices and TRIANGLES triangles,
//     positions as float32 (what WebGL draws), finite, normals of unit length, colours in
//     [0, 1];
//   - the OBJ (Y up by default): TRIANGLES triangles with vertex colours;
//   - the bounding boxes of the PLY (plus its `comment origin`), the OBJ and the glTF
//     (POSITION min/max plus the root node's translation) agree to 1 mm.
// Exit status 0 when every check passed, 1 otherwise, 2 on usage.
//
//   node read_exports.mjs NODE_MODULES_DIR VERTICES TRIANGLES FILE.ply FILE.obj FILE.gltf
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const args = process.argv.slice(2);
if (args.length !== 6) {
    console.error('usage: node read_exports.mjs NODE_MODULES_DIR VERTICES TRIANGLES PLY OBJ GLTF');
    process.exit(2);
}
const [modules, vertices, triangles, plyFile, objFile, gltfFile] = args;
const load = (p) => import(pathToFileURL(path.join(modules, p)).href);
const { PLYLoader } = await load('three/examples/jsm/loaders/PLYLoader.js');
const { OBJLoader } = await load('three/examples/jsm/loaders/OBJLoader.js');

let failures = 0;
function check(ok, what) {
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
    if (!ok) failures += 1;
}

function newBox() {
    return { min: [Infinity, Infinity, Infinity], max: [-Infinity, -Infinity, -Infinity] };
}
function grow(box, x, y, z) {
    [x, y, z].forEach((v, k) => {
        box.min[k] = Math.min(box.min[k], v);
        box.max[k] = Math.max(box.max[k], v);
    });
}
const show = (b) => `[${b.min.map((v) => v.toFixed(4))}] .. [${b.max.map((v) => v.toFixed(4))}]`;

// The PLY
const plyBytes = fs.readFileSync(plyFile);
const header = plyBytes.subarray(0, plyBytes.indexOf('end_header')).toString('latin1');
const originLine = header.split('\n').find((l) => l.startsWith('comment origin '));
const origin = originLine ? originLine.split(/\s+/).slice(2, 5).map(Number) : [0, 0, 0];
const ply = new PLYLoader().parse(plyBytes.buffer.slice(plyBytes.byteOffset,
                                                        plyBytes.byteOffset + plyBytes.length));
const pos = ply.getAttribute('position');
const nor = ply.getAttribute('normal');
const col = ply.getAttribute('color');
check(pos && pos.count === Number(vertices), `${plyFile}: ${pos ? pos.count : 0} vertices (abrad: ${vertices})`);
check(ply.index && ply.index.count === 3 * Number(triangles),
      `${plyFile}: ${ply.index ? ply.index.count / 3 : 0} triangles (abrad: ${triangles})`);
check(nor && col, `${plyFile}: normals and colours read`);
// WebGL draws float32 attributes only: three.js keeps double positions as a Float64Array,
// which its renderer refuses
check(pos && pos.array instanceof Float32Array,
      `${plyFile}: positions as ${pos ? pos.array.constructor.name : '-'} (WebGL needs Float32Array)`);
const plyBox = newBox();
let finite = true, unit = true, inRange = true;
for (let i = 0; pos && i < pos.count; ++i) {
    const p = [pos.getX(i), pos.getY(i), pos.getZ(i)];
    finite &&= p.every(Number.isFinite);
    grow(plyBox, p[0] + origin[0], p[1] + origin[1], p[2] + origin[2]);
    if (nor) unit &&= Math.abs(Math.hypot(nor.getX(i), nor.getY(i), nor.getZ(i)) - 1) < 1e-4;
    if (col) inRange &&= [col.getX(i), col.getY(i), col.getZ(i)].every((c) => c >= 0 && c <= 1);
}
check(finite && unit && inRange, `${plyFile}: finite positions, unit normals, colours in [0, 1]`);

// The OBJ
const obj = new OBJLoader().parse(fs.readFileSync(objFile, 'utf8'));
const objBox = newBox();
let objTriangles = 0, objColours = true;
obj.traverse((o) => {
    if (!o.isMesh) return;
    const p = o.geometry.getAttribute('position');
    objTriangles += p.count / 3;  // OBJLoader unrolls faces
    objColours &&= Boolean(o.geometry.getAttribute('color'));
    for (let i = 0; i < p.count; ++i) grow(objBox, p.getX(i), p.getY(i), p.getZ(i));
});
check(objTriangles === Number(triangles), `${objFile}: ${objTriangles} triangles (abrad: ${triangles})`);
check(objColours, `${objFile}: vertex colours read`);

// The glTF's box from its accessors' bounds
const gltf = JSON.parse(fs.readFileSync(gltfFile, 'utf8'));
const root = gltf.nodes[gltf.scenes[0].nodes[0]];
const t = root.translation || [0, 0, 0];
const gltfBox = newBox();
for (const mesh of gltf.meshes)
    for (const prim of mesh.primitives) {
        const a = gltf.accessors[prim.attributes.POSITION];
        grow(gltfBox, a.min[0] + t[0], a.min[1] + t[1], a.min[2] + t[2]);
        grow(gltfBox, a.max[0] + t[0], a.max[1] + t[1], a.max[2] + t[2]);
    }

const same = (a, b) => [0, 1, 2].every((k) => Math.abs(a.min[k] - b.min[k]) <= 1e-3 &&
                                              Math.abs(a.max[k] - b.max[k]) <= 1e-3);
console.log(`boxes (Y up, metres): ply ${show(plyBox)}, obj ${show(objBox)}, gltf ${show(gltfBox)}`);
check(same(plyBox, objBox) && same(plyBox, gltfBox), 'PLY, OBJ and glTF boxes agree to 1 mm');
process.exit(failures ? 1 : 0);
