// Validates glTF/GLB files with the Khronos glTF validator (npm gltf-validator, installed into
// the build folder by tests/export/npm_install.sh). Prints each file's counts and its issues;
// exit status 0 when no file has an error or a warning, 1 otherwise, 2 on usage.
//
//   node validate_gltf.cjs NODE_MODULES_DIR FILE...
'use strict';
const fs = require('fs');
const path = require('path');

async function main(argv) {
    if (argv.length < 2) {
        console.error('usage: node validate_gltf.cjs NODE_MODULES_DIR FILE...');
        return 2;
    }
    const validator = require(path.resolve(argv[0], 'gltf-validator'));
    let failed = 0;
    for (const file of argv.slice(1)) {
        const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
            uri: path.basename(file),
            maxIssues: 0,
            writeTimestamp: false,
        });
        const i = report.issues;
        console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ` +
                    `${i.numInfos} infos, ${i.numHints} hints (gltf-validator ${validator.version()})`);
        // Severity 0 error, 1 warning, 2 info, 3 hint: list the first few of each code
        const seen = new Map();
        for (const m of i.messages) {
            const n = (seen.get(m.code) || 0) + 1;
            seen.set(m.code, n);
            if (n <= 3) console.log(`  [${m.severity}] ${m.code} at ${m.pointer || '-'}: ${m.message}`);
        }
        for (const [code, n] of seen) if (n > 3) console.log(`  ... ${code}: ${n} in all`);
        if (i.numErrors > 0 || i.numWarnings > 0) failed += 1;
    }
    return failed ? 1 : 0;
}

main(process.argv.slice(2)).then((code) => process.exit(code), (error) => {
    console.error(`validate_gltf: ${error}`);
    process.exit(1);
});
